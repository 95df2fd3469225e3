// The grid checker, the exact answer at 10^5-10^6 boxes: it agrees with the
// brute-force oracle on every box set and size of the finder tests (touching,
// one ulp apart, degenerate, NaN, inverted, infinite) and with cpusap at 100000.
#include "gpu/pairs/grid_pair_checker.h"

#include <gtest/gtest.h>

#include <limits>
#include <random>
#include <vector>

#include "gpu/cpu/cpu_sweep_and_prune.h"
#include "gpu/pairs/pair_set.h"
#include "tests/gpu/pair_test_support.h"

namespace overlap::finders {
namespace {

std::vector<std::uint64_t> oracleKeys(std::span<const ObjectBounds> boxes) {
  std::vector<std::uint64_t> keys;
  for (const IndexPair& pair : testing::oraclePairs(boxes)) keys.push_back(pairKey(pair.a, pair.b));
  return keys;
}

TEST(GridPairCheckerTest, AgreesWithTheBruteForceOnEveryBoxSet) {
  for (const testing::BoxSet set : testing::kAllBoxSets) {
    for (const std::uint32_t n : {0u, 1u, 31u, 32u, 33u, 700u}) {
      for (int frame = 0; frame < 3; ++frame) {
        const std::vector<ObjectBounds> boxes = testing::makeBoxes(set, n, frame);
        EXPECT_EQ(gridCheckerPairs(boxes), oracleKeys(boxes))
            << testing::boxSetName(set) << ", n = " << n << ", frame " << frame;
      }
    }
  }
}

TEST(GridPairCheckerTest, BoxesOffTheGridPairAsTheBruteForceDoes) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  std::vector<ObjectBounds> boxes = testing::makeBoxes(testing::BoxSet::kRandom, 400, 0);
  boxes[3] = testing::box(kNaN, 0, 0, 1, 1, 1);
  boxes[4] = testing::box(5, 5, 5, 4, 6, 6);  // inverted
  boxes[5] = testing::box(5, 5, 5, 4, 6, 6);  // the same: they pair
  boxes[6] = testing::box(-kInf, 2, 2, kInf, 3, 3);
  boxes[7] = testing::box(-1e6f, -1e6f, -1e6f, 1e6f, 1e6f, 1e6f);  // over many cells
  EXPECT_EQ(gridCheckerPairs(boxes), oracleKeys(boxes));
}

TEST(GridPairCheckerTest, AgreesWithCpusapAtAHundredThousandBoxes) {
  // A dense layer of three size classes, as scene 4's pile.
  std::mt19937 random(5);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::vector<ObjectBounds> boxes(100000);
  for (std::uint32_t i = 0; i < boxes.size(); ++i) {
    const float lo[3] = {0.1f, 0.8f, 1.6f}, hi[3] = {0.4f, 1.2f, 4.0f};
    const float edge = lo[i % 3] + (hi[i % 3] - lo[i % 3]) * unit(random);
    const float extent[3] = {200.0f, 12.0f, 200.0f};
    for (int axis = 0; axis < 3; ++axis) {
      const float centre = extent[axis] * unit(random);
      boxes[i].min[axis] = centre - 0.5f * edge;
      boxes[i].max[axis] = centre + 0.5f * edge;
    }
    boxes[i].group = 1;
    boxes[i].mask = -1;
  }
  CpuSweepAndPruneFinder sap;
  sap.launch(boxes);
  const PairDelta delta = sap.finish();
  std::vector<std::uint64_t> found;
  for (const IndexPair& pair : delta.added) found.push_back(pairKey(pair.a, pair.b));
  const std::vector<std::uint64_t> checked = gridCheckerPairs(boxes);
  EXPECT_GT(checked.size(), boxes.size());
  EXPECT_EQ(found, checked);
}

}  // namespace
}  // namespace overlap::finders
