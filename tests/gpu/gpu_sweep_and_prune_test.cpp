// gpusap against cpubf frame by frame at CUB's boundary sizes, on a stream
// of many small boxes and a few huge ones (one spanning the world), across a
// frame that outgrows its room, against the grid checker at 100000 boxes,
// and what one frame asks of the bus and the host.  Skips,
// saying why, without a CUDA device (the emulation build runs it).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "gpu/cpu/cpu_brute_force.h"
#include "gpu/pair_finder.h"
#include "gpu/pairs/grid_pair_checker.h"
#include "tests/gpu/pair_test_support.h"
#include "tests/needs_device.h"

namespace overlap::finders {
namespace {

using testing::BoxSet;

class GpuSapTest : public ::testing::Test {
 protected:
  void SetUp() override { OVERLAP_NEEDS_DEVICE_FOR("gpusap"); }
};

TEST_F(GpuSapTest, SameDeltasAsCpubfAtTheCubBoundarySizes) {
  for (const BoxSet set : testing::kAllBoxSets) {
    for (const std::uint32_t n : {0u, 1u, 31u, 32u, 33u, 1023u, 1025u, 4096u}) {
      // 4096 identical boxes make 8 million pairs: 1025 has the many-pairs path.
      if (set == BoxSet::kIdentical && n > 1025) continue;
      SCOPED_TRACE(testing::boxSetName(set) + ", n = " + std::to_string(n));
      const auto gpusap = makePairFinder("gpusap");
      CpuBruteForceFinder cpubf;
      for (int frame = 0; frame < 4; ++frame) {
        ASSERT_TRUE(testing::sameDeltaAs(*gpusap, cpubf, testing::makeBoxes(set, n, frame)))
            << "frame " << frame;
      }
    }
  }
}

// Scene 4's spread of sizes taken further: thousands of boxes a tenth of the
// base size, a few four times it, and a few that cross the whole scene on
// the sweep axis, so one box's candidates are every box; all moving.
std::vector<ObjectBounds> skewedBoxes(std::uint32_t n, int frame) {
  std::mt19937 random(77u + static_cast<unsigned>(frame));
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::vector<ObjectBounds> boxes(n);
  const float side = 40.0f;
  for (std::uint32_t i = 0; i < n; ++i) {
    const float edge = i % 500 == 0 ? 4.0f : (i % 500 == 1 ? 0.4f : 0.1f + 0.3f * unit(random));
    for (int axis = 0; axis < 3; ++axis) {
      const float centre = side * unit(random);
      boxes[i].min[axis] = centre - 0.5f * edge;
      boxes[i].max[axis] = centre + 0.5f * edge;
    }
    boxes[i].group = 1;
    boxes[i].mask = -1;
    if (i % 1000 == 7) {  // a plank across the whole scene on every axis but one
      for (int axis = 0; axis < 3; ++axis) {
        boxes[i].min[axis] = axis == 1 ? boxes[i].min[axis] : -1.0f;
        boxes[i].max[axis] = axis == 1 ? boxes[i].max[axis] : side + 1.0f;
      }
    }
  }
  return boxes;
}

TEST_F(GpuSapTest, ManySmallBoxesAndAFewHugeOnesStayExact) {
  const auto gpusap = makePairFinder("gpusap");
  CpuBruteForceFinder cpubf;
  for (int frame = 0; frame < 5; ++frame) {
    ASSERT_TRUE(testing::sameDeltaAs(*gpusap, cpubf, skewedBoxes(6000, frame)))
        << "frame " << frame;
  }
}

// The skewed boxes with one more that spans the whole scene on every axis
// (it reaches every slab and pairs with every box), at CUB's boundary sizes
// and above.
TEST_F(GpuSapTest, ABoxSpanningTheWorldPairsWithEveryBoxAtEverySize) {
  for (const std::uint32_t n : {1u, 2u, 31u, 32u, 33u, 1023u, 1025u, 6000u}) {
    SCOPED_TRACE("n = " + std::to_string(n));
    const auto gpusap = makePairFinder("gpusap");
    CpuBruteForceFinder cpubf;
    for (int frame = 0; frame < 3; ++frame) {
      std::vector<ObjectBounds> boxes = skewedBoxes(n, frame);
      boxes[n / 2] = testing::box(-1, -1, -1, 41, 41, 41);
      ASSERT_TRUE(testing::sameDeltaAs(*gpusap, cpubf, boxes)) << "frame " << frame;
    }
  }
}

// Far from the origin on the sweep axis, where the entry sort's dropped low
// bits (a slab's width of them) join starts several units apart: boxes
// whose sort keys tie while their starts, ends and overlaps differ.
TEST_F(GpuSapTest, StartsCloserThanTheSortsResolutionStayExact) {
  const auto gpusap = makePairFinder("gpusap");
  CpuBruteForceFinder cpubf;
  for (int frame = 0; frame < 3; ++frame) {
    std::mt19937 random(5u + static_cast<unsigned>(frame));
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::vector<ObjectBounds> boxes;
    for (std::uint32_t i = 0; i < 4096; ++i) {
      const float x = 300000.0f + 400.0f * unit(random);
      const float y = 40.0f * unit(random);
      const float z = 40.0f * unit(random);
      const float edge = i % 3 == 0 ? 0.03125f : 2.0f * unit(random);  // the least float step there
      boxes.push_back(testing::box(x, y, z, x + edge, y + 2.0f, z + 2.0f));
    }
    ASSERT_TRUE(testing::sameDeltaAs(*gpusap, cpubf, boxes)) << "frame " << frame;
  }
}

// Sparse, then every box on one spot (half a million pairs, far past the
// room the sparse frames left), then sparse again: the crowded frame runs
// again with room, and last frame's set survives its first run whole.
TEST_F(GpuSapTest, AFrameThatOutgrowsItsRoomRunsAgainAndStaysExact) {
  const auto gpusap = makePairFinder("gpusap");
  CpuBruteForceFinder cpubf;
  for (int frame = 0; frame < 4; ++frame) {
    const BoxSet set = frame == 2 ? BoxSet::kIdentical : BoxSet::kRandom;
    ASSERT_TRUE(testing::sameDeltaAs(*gpusap, cpubf, testing::makeBoxes(set, 1000, frame)))
        << "frame " << frame;
  }
}

TEST_F(GpuSapTest, NaNInvertedInfiniteAndUnusedBoxesPairAsCpubfDoes) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  const auto gpusap = makePairFinder("gpusap");
  CpuBruteForceFinder cpubf;
  for (int frame = 0; frame < 3; ++frame) {
    std::vector<ObjectBounds> boxes = testing::makeBoxes(BoxSet::kRandom, 300, frame);
    boxes[3] = testing::box(kNaN, 0, 0, 1, 1, 1);
    boxes[4] = testing::box(5, 5, 5, 4, 6, 6);  // inverted on x
    boxes[5] = testing::box(5, 5, 5, 4, 6, 6);  // the same: they pair
    boxes[6] = testing::box(-kInf, -kInf, -kInf, kInf, kInf, kInf);
    boxes[7] = testing::box(0, 0, 0, 1, 1, kNaN);
    boxes[8] = testing::box(-0.0f, 0, 0, 1, 1, 1);  // -0 meets +0
    boxes[9] = testing::box(-1, 0, 0, 0.0f, 1, 1);
    boxes[10] = testing::box(0, 0, 0, 1, 1, 1, 0, 0);  // unused slot
    if (frame == 2) boxes[6] = testing::box(kInf, kInf, kInf, kInf, kInf, kInf);
    ASSERT_TRUE(testing::sameDeltaAs(*gpusap, cpubf, boxes)) << "frame " << frame;
  }
}

// A square pile (155 x 155 x 20) of scene 4's three size classes, as dense
// as a pile (about four pairs a box): about 900 candidates a box along one
// axis, a few tens within the slabs of a second, which is what lets the
// emulation run it in seconds.
TEST_F(GpuSapTest, ExactAgainstTheGridCheckerAtAHundredThousandBoxes) {
  const auto gpusap = makePairFinder("gpusap");
  const float extent[3] = {155.0f, 155.0f, 20.0f};
  std::vector<std::uint64_t> pairs;  // last frame's, as pairKey()s, sorted
  for (int frame = 0; frame < 2; ++frame) {
    const std::vector<ObjectBounds> boxes = testing::pileOfThreeSizes(100000, extent, frame);
    gpusap->launch(boxes);
    const PairDelta delta = gpusap->finish();
    std::vector<std::uint64_t> now = pairs;
    for (const IndexPair& pair : delta.removed) {
      const auto found = std::lower_bound(now.begin(), now.end(), pairKey(pair.a, pair.b));
      ASSERT_TRUE(found != now.end() && *found == pairKey(pair.a, pair.b));
      now.erase(found);
    }
    std::vector<std::uint64_t> added;
    for (const IndexPair& pair : delta.added) added.push_back(pairKey(pair.a, pair.b));
    std::vector<std::uint64_t> merged;
    std::merge(now.begin(), now.end(), added.begin(), added.end(), std::back_inserter(merged));
    const std::vector<std::uint64_t> expected = gridCheckerPairs(boxes);
    ASSERT_EQ(merged, expected) << "frame " << frame;
    EXPECT_GT(expected.size(), 100000u) << "the layer is dense";
    pairs = std::move(merged);
  }
}

TEST_F(GpuSapTest, OnlyBoxesGoUpAndOnlyTheResultBlockComesBackWithNoHostSort) {
  const auto gpusap = makePairFinder("gpusap");
  const std::vector<ObjectBounds> boxes = testing::makeBoxes(BoxSet::kRandom, 2000, 0);
  gpusap->launch(boxes);
  gpusap->finish();
  gpusap->launch(boxes);  // nothing moved: nothing changes
  const PairDelta delta = gpusap->finish();
  EXPECT_TRUE(delta.added.empty());
  EXPECT_TRUE(delta.removed.empty());
  const DeviceWork work = gpusap->lastStats().device;
  EXPECT_EQ(work.bytes_to_device, boxes.size() * sizeof(ObjectBounds));
  // Four counts and the changes' head (4096 entries), whatever the counts;
  // nothing beyond.
  EXPECT_EQ(work.bytes_from_device, 4 * sizeof(unsigned long long) + 4096 * sizeof(IndexPair));
  EXPECT_EQ(work.host_entries_sorted, 0u);
  EXPECT_EQ(work.host_bytes_copied, boxes.size() * sizeof(ObjectBounds)) << "the staging copy";
  EXPECT_GT(work.api_calls, 10u);
}

}  // namespace
}  // namespace overlap::finders
