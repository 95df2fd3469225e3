// What the GPU finders report of a frame (PairFinder::lastStats().device),
// against what the CUDA emulation counted, and gpubf's changes sorted on the
// device: the host sorts only a list longer than the result block's head.
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

#include "gpu/emulation/api_counters.h"
#include "gpu/pair_finder.h"
#include "tests/gpu/frame_cost.h"
#include "tests/gpu/pair_test_support.h"

namespace overlap::finders {
namespace {

using testing::box;

// gpubf's copy back: both counts (two pairs of 64-bit counters) and the
// first 4096 entries of both lists.
constexpr std::uint64_t kResultBlockBytes = 2 * 2 * 8 + 2 * 4096 * sizeof(IndexPair);
constexpr std::size_t kHeadEntries = 4096;

// One frame of `finder` over `boxes`, through its staging when `staged`;
// returns what the emulation counted between launch() and finish()'s return.
cuda_emulation::ApiCounters countedFrame(PairFinder& finder, std::span<const ObjectBounds> boxes,
                                         bool staged, PairDelta* delta = nullptr) {
  std::span<const ObjectBounds> passed = boxes;
  if (const std::span<ObjectBounds> staging = finder.stagingFor(boxes.size());
      staged && !staging.empty()) {
    std::copy(boxes.begin(), boxes.end(), staging.begin());
    passed = staging;
  }
  const cuda_emulation::ApiCounters before = cuda_emulation::apiCounters();
  finder.launch(passed);
  const PairDelta result = finder.finish();
  if (delta != nullptr) *delta = result;
  return cuda_emulation::apiCounters() - before;
}

TEST(GpubfDeviceWorkTest, ASteadyFrameIsOneGraphLaunchAndOneWait) {
  for (const std::uint32_t n : {0u, 1u, 2u, 31u, 32u, 33u, 1023u, 1025u}) {
    for (const bool staged : {true, false}) {
      SCOPED_TRACE("n = " + std::to_string(n) + (staged ? ", staged" : ", pageable"));
      const auto finder = makePairFinder("gpubf");
      for (int frame = 0; frame < 3; ++frame) {
        countedFrame(*finder, testing::steppingBoxes(n, frame), staged);
      }
      const cuda_emulation::ApiCounters counted =
          countedFrame(*finder, testing::steppingBoxes(n, 3), staged);
      const DeviceWork work = finder->lastStats().device;
      EXPECT_EQ(work.api_calls, counted.api_calls);
      EXPECT_EQ(work.bytes_to_device, counted.bytes_to_device);
      EXPECT_EQ(work.bytes_from_device, counted.bytes_to_host);
      EXPECT_EQ(work.bytes_to_device, 32u * n);
      EXPECT_EQ(work.bytes_from_device, kResultBlockBytes);
      // The frame's chain is the graph the frame two before captured: one
      // call launches it, one waits.  In it: four events, the upload, one
      // kernel and the copy back; no kernel below two slots, no upload of none.
      EXPECT_EQ(work.api_calls, 2u);
      EXPECT_EQ(counted.event_records, 4u);
      EXPECT_EQ(counted.copies_to_device, n > 0 ? 1u : 0u);
      EXPECT_EQ(counted.kernel_launches, n >= 2 ? 1u : 0u);
      EXPECT_EQ(counted.copies_to_host, 1u);
      EXPECT_EQ(counted.host_waits, 1u);
      EXPECT_EQ(work.host_bytes_copied, staged ? 0u : 32u * n);
      EXPECT_EQ(work.host_entries_sorted, 0u);
      // The three stages are contiguous: together they are the search, end to end.
      EXPECT_NEAR(work.upload_ms + work.kernels_ms + work.download_ms,
                  finder->lastStats().search_ms, 1e-3);
    }
  }
}

// A frame whose sizes are new captures its chain again (more calls, the same
// answer); two frames later the new graph is replayed.
TEST(GpubfDeviceWorkTest, AGrownFrameIsCapturedAgainThenReplayed) {
  const auto finder = makePairFinder("gpubf");
  std::vector<IndexPair> pairs;
  int frame = 0;
  for (const std::uint32_t n : {40u, 40u, 40u, 300u, 300u, 300u, 300u}) {
    SCOPED_TRACE("frame " + std::to_string(frame) + ", n = " + std::to_string(n));
    const std::vector<ObjectBounds> boxes = testing::steppingBoxes(n, frame);
    testing::expectFrameMatchesOracle(*finder, boxes, pairs);
    const std::uint64_t calls = finder->lastStats().device.api_calls;
    const bool replayed = frame == 2 || frame >= 5;
    if (replayed) {
      EXPECT_EQ(calls, 2u);
    } else {
      EXPECT_GT(calls, 2u) << "a capture: begin, the chain's calls, end, instantiate, launch";
    }
    ++frame;
  }
}

TEST(GpubfPaperDeviceWorkTest, CountsEveryPairsByteAndTheHostSort) {
  for (const std::uint32_t n : {2u, 33u, 1025u}) {
    SCOPED_TRACE("n = " + std::to_string(n));
    const auto finder = makePairFinder("gpubf-paper");
    countedFrame(*finder, testing::steppingBoxes(n, 0), false);
    PairDelta delta;
    const cuda_emulation::ApiCounters counted =
        countedFrame(*finder, testing::steppingBoxes(n, 1), false, &delta);
    const DeviceWork work = finder->lastStats().device;
    EXPECT_EQ(work.api_calls, counted.api_calls);
    EXPECT_EQ(work.bytes_to_device, 32u * n);
    EXPECT_EQ(work.bytes_from_device, std::uint64_t{n} * (n - 1) / 2);
    EXPECT_EQ(work.bytes_from_device, counted.bytes_to_host);
    EXPECT_EQ(work.host_bytes_copied, 0u);
    EXPECT_EQ(work.host_entries_sorted, delta.added.size() + delta.removed.size());
    EXPECT_GT(work.host_entries_sorted, 0u);
  }
}

// 300 slots, shuffled, holding cliques of identical boxes (every pair inside
// one overlaps) that add up to exactly `pairs` pairs; the rest apart.
std::vector<ObjectBounds> shuffledCliques(std::size_t pairs, std::uint32_t seed) {
  constexpr std::uint32_t kSlots = 300;
  std::vector<ObjectBounds> boxes;
  float x = 0;
  while (pairs > 0) {
    std::uint32_t size = 2;
    while (std::size_t{size} * (size + 1) / 2 <= pairs) ++size;  // largest with k(k-1)/2 <= pairs
    pairs -= std::size_t{size} * (size - 1) / 2;
    boxes.insert(boxes.end(), size, box(x, 0, 0, x + 1, 1, 1));
    x += 10;
  }
  while (boxes.size() < kSlots) {
    const float far = 1000.0f + 3.0f * static_cast<float>(boxes.size());
    boxes.push_back(box(far, 0, 0, far + 1, 1, 1));
  }
  std::shuffle(boxes.begin(), boxes.end(), std::mt19937(seed));
  return boxes;
}

TEST(GpubfDeviceSortTest, ChangesComeBackSortedWithNoHostSortUnlessAListOutgrowsItsHead) {
  // Each count of changes appears in one frame and disappears in the next;
  // 512 is the most the short sort takes (two keys a thread), 513 the fewest
  // the whole-head sort does, and 4097 overflows the head.
  for (const std::size_t changes :
       {0u, 1u, 31u, 32u, 33u, 512u, 513u, 1023u, 1025u, 4096u, 4097u}) {
    SCOPED_TRACE(std::to_string(changes) + " changes");
    const auto finder = makePairFinder("gpubf");
    const std::vector<ObjectBounds> apart = shuffledCliques(0, 7);
    const std::vector<ObjectBounds> together = shuffledCliques(changes, 7);
    ASSERT_EQ(testing::oraclePairs(together).size(), changes);
    std::vector<IndexPair> pairs;
    testing::expectFrameMatchesOracle(*finder, apart, pairs);
    for (const auto* boxes : {&together, &apart}) {
      testing::expectFrameMatchesOracle(*finder, *boxes, pairs);
      const DeviceWork work = finder->lastStats().device;
      const bool overflow = changes > kHeadEntries;
      EXPECT_EQ(work.host_entries_sorted, overflow ? changes : 0u);
      // The boxes come from pageable memory: staged by a host copy.
      EXPECT_EQ(work.host_bytes_copied, sizeof(ObjectBounds) * boxes->size() +
                                            (overflow ? kHeadEntries * sizeof(IndexPair) : 0u));
      EXPECT_EQ(work.bytes_from_device,
                kResultBlockBytes + (overflow ? (changes - kHeadEntries) * sizeof(IndexPair) : 0u));
    }
  }
}

}  // namespace
}  // namespace overlap::finders
