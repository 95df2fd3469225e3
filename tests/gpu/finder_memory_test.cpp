// Every finder holds no more than its row of the finder table says
// (PairFinderRow::memory, gpu/pair_finder.h), which the memory bounds count
// before a run allocates (engine/program/memory_bound.h).
//
// The host heap is counted by tests/counted_heap.h (the peak over each
// frame); in the CUDA emulation build the device and
// pinned memory too, by the emulation's allocation table (what is held after
// a frame: the GPU finders free a buffer before they allocate its larger
// one).  On a real GPU only the host is counted.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "gpu/pair_finder.h"
#include "tests/counted_heap.h"
#include "tests/gpu/pair_test_support.h"
#include "tests/needs_device.h"

#if OVERLAP_TEST_COUNTS_DEVICE
#include "gpu/emulation/api_counters.h"
#endif

namespace overlap::finders {
namespace {

// What a finder may hold besides its rates: a few fixed buffers (histograms,
// result blocks, a thread's first keys).
constexpr std::uint64_t kFixedBytes = 1 << 20;

// The most a finder held during its frames, from before it was made.
class HeldMemory {
 public:
  HeldMemory() : heap_before_(test_support::heapLive()) {}
  // Call after each frame.
  void frameEnded() {
    std::uint64_t held = static_cast<std::uint64_t>(
        std::max<std::int64_t>(test_support::takeHeapPeak() - heap_before_, 0));
#if OVERLAP_TEST_COUNTS_DEVICE
    held += cuda_emulation::liveDeviceBytes() + cuda_emulation::livePinnedBytes();
#endif
    most_ = std::max(most_, held);
  }
  std::uint64_t most() const {
    return most_;
  }

 private:
  std::int64_t heap_before_;
  std::uint64_t most_ = 0;
};

class FinderMemoryTest : public ::testing::TestWithParam<std::string_view> {
 protected:
  void SetUp() override { OVERLAP_NEEDS_DEVICE_FOR(GetParam()); }
  const MemoryCost& cost() const { return pairFinderRow(GetParam()).memory; }
};

// A grid of boxes that pair with nothing; a seventh of them moves each frame.
// Fewer for the brute forces, whose every frame tests every pair.
TEST_P(FinderMemoryTest, HoldsNoMoreThanItsRatesForBoxesThatPairWithNothing) {
  const std::uint32_t kBoxes = cost().per_slot_pair > 0 ? 4000 : 40000;
  std::vector<ObjectBounds> boxes(kBoxes);
  for (std::uint32_t i = 0; i < kBoxes; ++i) {
    const float x = static_cast<float>(i % 200) * 3, y = static_cast<float>(i / 200) * 3;
    boxes[i] = testing::box(x, y, 0, x + 1, y + 1, 1);
  }
  test_support::takeHeapPeak();
#if OVERLAP_TEST_COUNTS_DEVICE
  ASSERT_EQ(cuda_emulation::liveDeviceBytes() + cuda_emulation::livePinnedBytes(), 0u);
#endif
  HeldMemory held;
  {
    const auto finder = makePairFinder(GetParam());
    for (std::uint32_t frame = 0; frame < 3; ++frame) {
      for (std::uint32_t i = frame; i < kBoxes; i += 7) boxes[i].max[2] += 0.01f;
      finder->launch(boxes);
      ASSERT_TRUE(finder->finish().added.empty());
      held.frameEnded();
    }
  }
  const double bit_bytes =
      static_cast<double>(cost().bytesFor(kBoxes, 0) - kBoxes * cost().per_slot);
  std::printf("%s: %.1f bytes a box besides its pair bits (its rate: %u)\n",
              std::string(GetParam()).c_str(),
              (static_cast<double>(held.most()) - bit_bytes) / kBoxes, cost().per_slot);
  EXPECT_LE(held.most(), cost().bytesFor(kBoxes, 0) + kFixedBytes)
      << GetParam() << " holds " << held.most() / kBoxes << " bytes a box";
}

// Two clumps of boxes, every box of a clump overlapping every other; frame by
// frame the clumps are the two halves, then the even and the odd boxes, so
// half the pairs are removed and as many added.  Box counts on either side of
// the lists' doublings.
TEST_P(FinderMemoryTest, HoldsNoMoreThanItsRatesWhileClumpsOfPairsChange) {
  for (const std::uint32_t boxes_count : {900u, 1300u}) {
    std::vector<ObjectBounds> boxes(boxes_count);
    const auto clump = [&](bool by_parity) {
      for (std::uint32_t i = 0; i < boxes_count; ++i) {
        const bool first = by_parity ? i % 2 == 0 : i < boxes_count / 2;
        const float x = first ? 0.0f : 5.0f;
        boxes[i] = testing::box(x, 0, 0, x + 1, 1, 1);
      }
    };
    test_support::takeHeapPeak();
    HeldMemory held;
    std::uint64_t pairs = 0;
    std::uint64_t most_pairs = 0;
    {
      const auto finder = makePairFinder(GetParam());
      for (int frame = 0; frame < 4; ++frame) {
        clump(frame % 2 == 1);
        finder->launch(boxes);
        const PairDelta delta = finder->finish();
        pairs += delta.added.size();
        pairs -= delta.removed.size();
        most_pairs = std::max(most_pairs, pairs);
        held.frameEnded();
      }
    }
    ASSERT_GT(most_pairs, std::uint64_t{boxes_count} * boxes_count / 5);
    const std::uint64_t for_slots = cost().bytesFor(boxes_count, 0);
    std::printf("%s, %u boxes: %.1f bytes a pair besides the slots' (its rate: %u)\n",
                std::string(GetParam()).c_str(), boxes_count,
                (static_cast<double>(held.most()) - static_cast<double>(for_slots)) /
                    static_cast<double>(most_pairs),
                cost().per_pair);
    EXPECT_LE(held.most(), cost().bytesFor(boxes_count, most_pairs) + kFixedBytes)
        << GetParam() << ", " << boxes_count << " boxes: it holds " << held.most() / most_pairs
        << " bytes a pair";
  }
}

// A frame with more pairs than the finder's pair limit: finish() refuses it,
// the finder having held no more than the limit's pairs (not the frame's
// 320 000), and every later launch refuses too.  A frame of exactly the
// limit's pairs passes.
TEST_P(FinderMemoryTest, AFramePastItsPairLimitIsRefusedBeforeItsListsGrowForIt) {
  constexpr std::uint32_t kBoxes = 800;  // one clump: 319 600 pairs
  constexpr std::uint64_t kPairs = std::uint64_t{kBoxes} * (kBoxes - 1) / 2;
  constexpr std::uint64_t kLimit = 5000;
  const std::vector<ObjectBounds> boxes(kBoxes, testing::box(0, 0, 0, 1, 1, 1));
  test_support::takeHeapPeak();
  HeldMemory held;
  {
    const auto finder = makePairFinder(GetParam());
    finder->setPairLimit(kLimit);
    finder->launch(boxes);
    try {
      (void)finder->finish();
      ADD_FAILURE() << GetParam() << ": " << kPairs << " pairs passed a limit of " << kLimit;
    } catch (const PairLimitError& refusal) {
      EXPECT_EQ(refusal.most_pairs, kLimit);
    }
    held.frameEnded();
    EXPECT_THROW(finder->launch(boxes), PairLimitError) << "a refused finder is spent";
  }
  EXPECT_LE(held.most(), cost().bytesFor(kBoxes, kLimit) + kFixedBytes)
      << GetParam() << " holds " << held.most() / kLimit << " bytes a pair of the limit";

  const auto finder = makePairFinder(GetParam());
  finder->setPairLimit(kPairs);
  finder->launch(boxes);
  EXPECT_EQ(finder->finish().added.size(), kPairs);
}

INSTANTIATE_TEST_SUITE_P(AllFinders, FinderMemoryTest, ::testing::ValuesIn(testing::finderNames()),
                         testing::finderTestName);

}  // namespace
}  // namespace overlap::finders
