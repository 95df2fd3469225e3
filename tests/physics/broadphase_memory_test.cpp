// A replay under a pair memory limit holds no more than the memory bounds
// count (engine/program/memory_bound.h): BroadphaseReplay::memoryCost()'s
// bytes for its boxes, plus the limit it was given for its pairs, whether it
// finds them all or refuses (PairMemoryError): a pair finder stops
// collecting a frame's pairs past what the limit could hold.  Every CPU
// broadphase; the heap (Bullet's allocations too) counted by
// tests/counted_heap.h.
#include <LinearMath/btAlignedAllocator.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "physics/broadphase/broadphase_factory.h"
#include "physics/broadphase/bulk_pair_cache.h"
#include "physics/broadphase_replay.h"
#include "tests/counted_heap.h"

namespace overlap::physics {
namespace {

// What a replay may hold beyond its count and the fixed part it holds for
// one box (Bullet's collision configuration's pools, 4.4 MB).
constexpr std::uint64_t kSlackBytes = 256 << 10;

class BroadphaseMemoryTest : public ::testing::TestWithParam<std::string_view> {
 protected:
  // Bullet's allocations counted too: installed here, after the library's
  // own checked allocator (a static initializer's, of unspecified order).
  static void SetUpTestSuite() {
    btAlignedAllocSetCustom(test_support::countedAllocation, test_support::countedRelease);
  }

  // Replays `frames` under a pair limit of `pair_limit` bytes; the most the
  // heap held above where it started and above what a one-box replay holds,
  // and whether the limit refused a frame.
  std::uint64_t heldReplaying(const std::vector<std::vector<Aabb>>& frames,
                              std::uint64_t pair_limit, bool& refused) {
    const std::vector<std::vector<Aabb>> one_box(1, std::vector<Aabb>(1, frames[0][0]));
    (void)peakReplaying(one_box, pair_limit, refused);  // what a process does once, done
    const std::uint64_t fixed = peakReplaying(one_box, pair_limit, refused);
    const std::uint64_t peak = peakReplaying(frames, pair_limit, refused);
    return peak > fixed ? peak - fixed : 0;
  }

 private:
  std::uint64_t peakReplaying(const std::vector<std::vector<Aabb>>& frames,
                              std::uint64_t pair_limit, bool& refused) {
    refused = false;
    const std::int64_t before = test_support::heapLive();
    test_support::takeHeapPeak();
    {
      const Aabb world{{-10, -10, -10}, {1000, 1000, 10}};
      BroadphaseReplay replay(GetParam(), world, static_cast<int>(frames[0].size()));
      replay.setPairMemoryLimit(pair_limit);
      try {
        for (const std::vector<Aabb>& boxes : frames) {
          replay.update(boxes);
          replay.findPairs();
          (void)replay.pairs();
        }
      } catch (const PairMemoryError&) {
        refused = true;
      }
    }
    return static_cast<std::uint64_t>(test_support::takeHeapPeak() - before);
  }
};

TEST_P(BroadphaseMemoryTest, HoldsNoMoreThanItsCountForBoxesThatPairWithNothing) {
  const bool brute_force =
      GetParam() == "bf" || broadphaseInfo(GetParam()).memory.per_slot_pair > 0;
  const std::size_t boxes_count = brute_force ? 3000 : 10000;
  std::vector<std::vector<Aabb>> frames(3, std::vector<Aabb>(boxes_count));
  for (std::size_t frame = 0; frame < frames.size(); ++frame) {
    for (std::size_t i = 0; i < boxes_count; ++i) {
      const float x = static_cast<float>(i % 300) * 3, y = static_cast<float>(i / 300) * 3;
      const float lift = (i + frame) % 7 == 0 ? 0.01f * static_cast<float>(frame) : 0.0f;
      // 2 m boxes 1 m apart: sap's 16-bit cells stay fine enough for them.
      frames[frame][i] = {{x, y, lift}, {x + 2, y + 2, 2 + lift}};
    }
  }
  const std::uint64_t pair_limit = 1 << 20;
  bool refused = false;
  const std::uint64_t held = heldReplaying(frames, pair_limit, refused);
  EXPECT_FALSE(refused);
  const finders::MemoryCost cost = BroadphaseReplay::memoryCost(GetParam());
  std::printf("%s: %.1f bytes a box (counted: %u)\n", std::string(GetParam()).c_str(),
              static_cast<double>(held) / static_cast<double>(boxes_count), cost.per_slot);
  EXPECT_LE(held, cost.bytesFor(boxes_count, 0) + kSlackBytes);
}

// Two clumps of 1000 boxes each overlapping every other of its clump (a
// million pairs), the halves then the even and odd boxes, under limits that
// refuse them at once, part way and never.
TEST_P(BroadphaseMemoryTest, HoldsNoMoreThanItsCountUnderAPairLimit) {
  constexpr std::size_t kBoxes = 2000;
  std::vector<std::vector<Aabb>> frames(3, std::vector<Aabb>(kBoxes));
  for (std::size_t frame = 0; frame < frames.size(); ++frame) {
    for (std::size_t i = 0; i < kBoxes; ++i) {
      const bool first = frame % 2 == 0 ? i < kBoxes / 2 : i % 2 == 0;
      const float x = first ? 0.0f : 5.0f;
      frames[frame][i] = {{x, 0, 0}, {x + 1, 1, 1}};
    }
  }
  const finders::MemoryCost cost = BroadphaseReplay::memoryCost(GetParam());
  for (const std::uint64_t pair_limit :
       {std::uint64_t{8} << 20, std::uint64_t{60} << 20, std::uint64_t{1} << 30}) {
    bool refused = false;
    const std::uint64_t held = heldReplaying(frames, pair_limit, refused);
    const std::uint64_t for_boxes = cost.bytesFor(kBoxes, 0);
    std::printf("%s, limit %llu MiB: %s, held %.1f MiB for the pairs\n",
                std::string(GetParam()).c_str(), static_cast<unsigned long long>(pair_limit >> 20),
                refused ? "refused" : "whole",
                (static_cast<double>(held) - static_cast<double>(for_boxes)) / (1 << 20));
    EXPECT_LE(held, for_boxes + pair_limit + kSlackBytes) << "limit " << pair_limit;
    if (pair_limit == std::uint64_t{1} << 30) {
      EXPECT_FALSE(refused);
    }
    if (pair_limit == std::uint64_t{8} << 20) {
      EXPECT_TRUE(refused);
    }
  }
}

// The CPU ones: the GPU finders' rates are held by tests/gpu/finder_memory_test.cpp,
// and their adapter is the CPU finders'.
std::vector<std::string_view> runnableHere() {
  std::vector<std::string_view> names;
  for (const BroadphaseInfo& info : broadphaseCatalogue()) {
    if (!info.needs_device) names.push_back(info.name);
  }
  return names;
}

INSTANTIATE_TEST_SUITE_P(AllBroadphases, BroadphaseMemoryTest, ::testing::ValuesIn(runnableHere()),
                         [](const ::testing::TestParamInfo<std::string_view>& param) {
                           std::string name(param.param);
                           for (char& c : name) c = c == '-' ? '_' : c;
                           return name;
                         });

}  // namespace
}  // namespace overlap::physics
