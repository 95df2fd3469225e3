// gpusap's device memory, counted by the CUDA emulation's allocation table:
// at most 64 bytes per box slot plus 24 per pair, as its header promises.
// Emulation build only (the stand-ins' CUB temporaries are a few hundred
// bytes; CUB's own on a GPU are not counted here).
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "gpu/emulation/api_counters.h"
#include "gpu/pair_finder.h"
#include "tests/gpu/pair_test_support.h"

namespace overlap::gpu {
namespace {

TEST(GpuSapMemoryTest, AtMost64BytesPerBoxAnd24PerPair) {
  constexpr std::uint32_t kBoxes = 8000;
  constexpr std::uint64_t kFixedBytes = 4096;  // the frame's counters and CUB's temporaries
  const std::uint64_t before = cuda_emulation::liveDeviceBytes();
  const auto gpusap = makePairFinder(PairFinderKind::kGpuSweepAndPrune);
  const std::vector<ObjectBounds> boxes = testing::makeBoxes(testing::BoxSet::kTouching, kBoxes, 0);
  std::size_t pairs = 0;
  for (int frame = 0; frame < 3; ++frame) {  // every pair buffer in use by the third
    gpusap->launch(boxes);
    pairs += gpusap->finish().added.size();
  }
  ASSERT_GT(pairs, kBoxes / 2) << "enough pairs for their bytes to show";
  const std::uint64_t held = cuda_emulation::liveDeviceBytes() - before;
  EXPECT_LE(held, 64 * std::uint64_t{kBoxes} + 24 * pairs + kFixedBytes);
  EXPECT_GE(held, 56 * std::uint64_t{kBoxes} + 24 * pairs) << "the count sees every buffer";
}

}  // namespace
}  // namespace overlap::gpu
