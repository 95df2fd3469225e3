// gpusap's device memory, counted by the CUDA emulation's allocation table:
// 32 bytes per box slot, 32 per entry of capacity and 24 per pair of
// capacity, capacities as its header says (2 entries and 2 pairs a box at
// first; grown to 5/4 of a frame's count plus 64, at least doubling).
// Emulation build only (the stand-ins' CUB temporaries are a few hundred
// bytes; CUB's own on a GPU are not counted here).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "gpu/emulation/api_counters.h"
#include "gpu/pair_finder.h"
#include "tests/gpu/pair_test_support.h"

namespace overlap::finders {
namespace {

TEST(GpuSapMemoryTest, ThirtyTwoBytesPerBoxThirtyTwoPerEntryAndTwentyFourPerPairOfCapacity) {
  constexpr std::uint64_t kBoxes = 8000;
  // The frame's counters, the result block (32 KiB of changes) and CUB's temporaries.
  constexpr std::uint64_t kFixedBytes = 40 * 1024;
  const std::uint64_t before = cuda_emulation::liveDeviceBytes();
  const auto gpusap = makePairFinder("gpusap");
  const std::vector<ObjectBounds> boxes = testing::makeBoxes(testing::BoxSet::kTouching, kBoxes, 0);
  std::uint64_t pairs = 0;
  for (int frame = 0; frame < 3; ++frame) {  // every pair buffer in use by the third
    gpusap->launch(boxes);
    pairs += gpusap->finish().added.size();
  }
  ASSERT_GT(pairs, 2 * kBoxes) << "more pairs than the first guess, so the pair room grew";
  const std::uint64_t entry_capacity = 2 * kBoxes;  // touching boxes reach at most two slabs
  const std::uint64_t pair_capacity = std::max(pairs + pairs / 4 + 64, 2 * (2 * kBoxes));
  const std::uint64_t counted = 32 * kBoxes + 32 * entry_capacity + 24 * pair_capacity;
  const std::uint64_t held = cuda_emulation::liveDeviceBytes() - before;
  EXPECT_LE(held, counted + kFixedBytes);
  EXPECT_GE(held, counted) << "the count sees every buffer";
}

}  // namespace
}  // namespace overlap::finders
