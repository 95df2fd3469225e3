// cpusap beyond the oracle cases every finder runs (pair_finder_test.cpp):
// its two kernels and its thread counts give the same answer; the sweep axis
// and the slabs follow the boxes from frame to frame without losing a pair;
// boxes that cannot be swept (NaN, inverted, infinite) are handled as cpubf
// handles them; slots leave and return mid-run; and it agrees with cpubf on
// a long run of moving boxes.
#include "gpu/cpu/cpu_sap_pair_finder.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "gpu/cpu/cpu_pair_finder.h"
#include "gpu/pairs/pair_set.h"
#include "tests/gpu/pair_test_support.h"

namespace overlap::finders {
namespace {

using sap::SweepKernel;
using testing::box;
using testing::BoxSet;

constexpr float kInfinity = std::numeric_limits<float>::infinity();
constexpr float kQuietNaN = std::numeric_limits<float>::quiet_NaN();

// A pile like scene 4's: boxes of three size classes (0.1-0.4, 0.8-1.2,
// 1.6-4) in a layer `depth` thick on `flat_axis`, spread over a square of
// side `side` on the other two, drifting by `frame`.
std::vector<ObjectBounds> pile(std::uint32_t n, int frame, int flat_axis = 1, float side = 40.0f,
                               float depth = 6.0f) {
  std::mt19937 random(99u + n);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::vector<ObjectBounds> boxes(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    const float lo[3] = {0.1f, 0.8f, 1.6f}, hi[3] = {0.4f, 1.2f, 4.0f};
    const std::uint32_t size_class = i % 3;
    const float edge = lo[size_class] + (hi[size_class] - lo[size_class]) * unit(random);
    for (int axis = 0; axis < 3; ++axis) {
      const float extent = axis == flat_axis ? depth : side;
      const float drift = 0.05f * static_cast<float>(frame) * (unit(random) - 0.5f);
      const float centre = extent * unit(random) + drift;
      boxes[i].min[axis] = centre - 0.5f * edge;
      boxes[i].max[axis] = centre + 0.5f * edge;
    }
    boxes[i].group = 1;
    boxes[i].mask = -1;
  }
  return boxes;
}

TEST(CpuSapPairFinderTest, ScalarAndAvx2KernelsFindTheSamePairs) {
  if (!sap::avx2Available()) GTEST_SKIP() << "this CPU has no AVX2: only the scalar kernel runs";
  CpuSapPairFinder scalar(1, SweepKernel::kScalar);
  CpuSapPairFinder avx2(1, SweepKernel::kAvx2);
  EXPECT_EQ(scalar.kernel(), SweepKernel::kScalar);
  EXPECT_EQ(avx2.kernel(), SweepKernel::kAvx2);
  for (const BoxSet set : testing::kAllBoxSets) {
    for (int frame = 0; frame < 3; ++frame) {
      EXPECT_TRUE(testing::sameDeltaAs(avx2, scalar, testing::makeBoxes(set, 1025, frame)))
          << testing::boxSetName(set) << " frame " << frame;
    }
  }
}

TEST(CpuSapPairFinderTest, EachKernelMatchesTheOracleOnAPileWithManySlabs) {
  for (const SweepKernel kernel : {SweepKernel::kScalar, SweepKernel::kAvx2}) {
    if (kernel == SweepKernel::kAvx2 && !sap::avx2Available()) continue;
    CpuSapPairFinder finder(2, kernel);
    std::vector<IndexPair> pairs;
    for (int frame = 0; frame < 4; ++frame) {
      SCOPED_TRACE("kernel " + std::to_string(static_cast<int>(kernel)) + ", frame " +
                   std::to_string(frame));
      testing::expectFrameMatchesOracle(finder, pile(3000, frame), pairs);
      EXPECT_NE(finder.sweepAxis(), 1) << "the pile is flat on y";
      EXPECT_GT(finder.slabs().count, 4u) << "a wide pile should be cut into slabs";
    }
    EXPECT_GT(pairs.size(), 1000u);
  }
}

TEST(CpuSapPairFinderTest, LongThinBoxesCrossingManySlabsPairOnceWithEachBoxTheyMeet) {
  // Rods across the whole pile, along the sweep axis and along the slab
  // axis: a rod sits in every slab it crosses, and must still report each
  // pair once.  Some rods end exactly where others begin (touching).
  std::vector<ObjectBounds> boxes = pile(3000, 0);
  for (int r = 0; r < 40; ++r) {
    const float at = 1.0f * static_cast<float>(r);
    boxes.push_back(box(-1, 2, at, 41, 2.05f, at + 0.05f));  // along x
    boxes.push_back(box(at, 3, -1, at + 0.05f, 3.05f, 41));  // along z
    boxes.push_back(box(at, 2.05f, -1, at + 0.05f, 3, 41));  // touching both layers
  }
  CpuSapPairFinder finder;
  std::vector<IndexPair> pairs;
  for (int frame = 0; frame < 2; ++frame) {
    testing::expectFrameMatchesOracle(finder, boxes, pairs);
    EXPECT_GT(finder.slabs().count, 4u);
    for (ObjectBounds& b : boxes)
      b.min[1] = std::nextafter(b.min[1], kInfinity);  // some pairs leave
  }
}

TEST(CpuSapPairFinderTest, TheFastestKernelIsAvx2WhereTheCpuHasIt) {
  EXPECT_EQ(CpuSapPairFinder().kernel(),
            sap::avx2Available() ? SweepKernel::kAvx2 : SweepKernel::kScalar);
  if (!sap::avx2Available()) {
    EXPECT_THROW(CpuSapPairFinder(defaultTaskSystem(), SweepKernel::kAvx2), std::runtime_error);
  }
}

TEST(CpuSapPairFinderTest, ThreadCountDoesNotChangeTheAnswer) {
  // Every finder must see every frame: one single-thread reference per comparison.
  CpuSapPairFinder one(1), one_again(1), two(2), four(4);
  for (int frame = 0; frame < 5; ++frame) {
    const std::vector<ObjectBounds> boxes = pile(5000, frame);
    EXPECT_TRUE(testing::sameDeltaAs(two, one, boxes)) << "2 threads, frame " << frame;
    EXPECT_TRUE(testing::sameDeltaAs(four, one_again, boxes)) << "4 threads, frame " << frame;
  }
}

TEST(CpuSapPairFinderTest, SweepAxisFollowsTheWidestSpreadAndPairsStayExact) {
  // The pile lies flat on z, then on x, then on y: the sweep axis must move
  // each time (a full re-sort), and the deltas across the switch stay exact.
  CpuSapPairFinder finder;
  std::vector<IndexPair> pairs;
  std::vector<int> axes;
  for (const int flat_axis : {2, 2, 0, 0, 1, 1}) {
    SCOPED_TRACE("flat on axis " + std::to_string(flat_axis));
    std::vector<ObjectBounds> boxes = pile(1500, 0, flat_axis, 30.0f, 3.0f);
    // Stretch one of the two wide axes so that the widest is unambiguous.
    const int widest = (flat_axis + 1) % 3;
    for (ObjectBounds& b : boxes) {
      b.min[widest] *= 3.0f;
      b.max[widest] *= 3.0f;
    }
    testing::expectFrameMatchesOracle(finder, boxes, pairs);
    EXPECT_EQ(finder.sweepAxis(), widest);
    EXPECT_EQ(finder.slabs().count > 1, true);
    axes.push_back(finder.sweepAxis());
  }
  EXPECT_NE(axes[0], axes[2]);
  EXPECT_NE(axes[2], axes[4]);
}

TEST(CpuSapPairFinderTest, SortsIncrementallyWhileBoxesMoveLittle) {
  CpuSapPairFinder finder;
  std::vector<IndexPair> pairs;
  testing::expectFrameMatchesOracle(finder, pile(2000, 0), pairs);
  EXPECT_FALSE(finder.lastSortWasIncremental()) << "the first frame has no order to start from";
  testing::expectFrameMatchesOracle(finder, pile(2000, 1), pairs);
  EXPECT_TRUE(finder.lastSortWasIncremental());
  // Every box jumps somewhere else: too many moves for an insertion sort.
  std::vector<ObjectBounds> shuffled = pile(2000, 1);
  std::mt19937 random(7);
  std::shuffle(shuffled.begin(), shuffled.end(), random);
  testing::expectFrameMatchesOracle(finder, shuffled, pairs);
  EXPECT_FALSE(finder.lastSortWasIncremental());
}

TEST(CpuSapPairFinderTest, SlotsLeaveAndReturnMidRun) {
  // As the Bullet adapter does: a destroyed proxy's slot is searched as unused
  // (group = mask = 0), later reused by a new box; new slots are appended.
  CpuSapPairFinder finder;
  std::vector<IndexPair> pairs;
  std::vector<ObjectBounds> boxes = pile(800, 0);
  std::mt19937 random(3);
  for (int frame = 1; frame < 12; ++frame) {
    SCOPED_TRACE("frame " + std::to_string(frame));
    const std::vector<ObjectBounds> moved = pile(static_cast<std::uint32_t>(boxes.size()), frame);
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      if (boxes[i].group != 0) boxes[i] = moved[i];
    }
    for (int k = 0; k < 40; ++k) {
      ObjectBounds& b = boxes[random() % boxes.size()];
      b = b.group == 0 ? moved[random() % moved.size()] : ObjectBounds{};
    }
    for (int k = 0; k < 25; ++k) boxes.push_back(boxes[random() % boxes.size()]);
    testing::expectFrameMatchesOracle(finder, boxes, pairs);
  }
}

TEST(CpuSapPairFinderTest, NaNInvertedAndInfiniteBoxesPairAsTheBruteForceDoes) {
  // cpubf's rule, read literally: NaN never pairs; an inverted interval
  // [2, 1] still meets [0, 3]; infinite coordinates compare as numbers.
  std::vector<ObjectBounds> boxes = pile(600, 0);
  boxes[3] = box(kQuietNaN, 0, 0, 1, 1, 1);
  boxes[4] = box(5, 5, 5, 4, 6, 6);                   // inverted on x
  boxes[5] = box(10, 2, 10, 11, 1, 11);               // inverted on y
  boxes[6] = box(-kInfinity, 2, 2, kInfinity, 3, 3);  // a slab through everything on x
  boxes[7] = box(-kInfinity, -kInfinity, -kInfinity, kInfinity, kInfinity, kInfinity);
  boxes[8] = box(kInfinity, kInfinity, kInfinity, kInfinity, kInfinity, kInfinity);
  boxes[9] = box(3, 3, 3, kQuietNaN, 4, 4);
  boxes[10] = box(5, 5, 5, 4, 6, 6);  // the inverted box again: they pair
  CpuSapPairFinder sap, checked;
  CpuPairFinder brute_force;
  std::vector<IndexPair> pairs;
  for (int frame = 0; frame < 3; ++frame) {
    SCOPED_TRACE("frame " + std::to_string(frame));
    EXPECT_TRUE(testing::sameDeltaAs(sap, brute_force, boxes));
    testing::expectFrameMatchesOracle(checked, boxes, pairs);
    // The box that pairs with everything leaves, then comes back.
    boxes[7] = frame == 0
                   ? ObjectBounds{}
                   : box(-kInfinity, -kInfinity, -kInfinity, kInfinity, kInfinity, kInfinity);
  }
}

TEST(CpuSapPairFinderTest, AgreesWithCpubfOnALongRunOfMovingBoxes) {
  CpuSapPairFinder sap;
  CpuPairFinder brute_force;
  for (int frame = 0; frame < 20; ++frame) {
    ASSERT_TRUE(testing::sameDeltaAs(sap, brute_force, pile(3000, frame))) << "frame " << frame;
  }
}

TEST(CpuSapPairFinderTest, FramesWithFewMovedBoxesQueryOnlyThoseAndStayExact) {
  // 1% of the boxes move each frame, far or by a hair, some become unused
  // or NaN and come back; every few frames many move, forcing a full search
  // that must take over the moved-box frames' pairs.
  std::vector<ObjectBounds> boxes = pile(3000, 0);
  const std::vector<ObjectBounds> elsewhere = pile(3000, 5);
  CpuSapPairFinder sap;
  CpuPairFinder brute_force;
  std::vector<IndexPair> pairs;
  std::mt19937 random(11);
  int moved_only = 0, full_after_moved_only = 0;
  bool last_was_moved_only = false;
  for (int frame = 0; frame < 40; ++frame) {
    SCOPED_TRACE("frame " + std::to_string(frame));
    const std::size_t moving = frame % 9 == 8 ? 400 : 30;
    for (std::size_t k = 0; k < moving; ++k) {
      const std::size_t i = random() % boxes.size();
      switch (random() % 6) {
        case 0:
          boxes[i] = ObjectBounds{};
          break;
        case 1:
          boxes[i].min[0] = kQuietNaN;
          break;
        case 2:
          boxes[i].max[1] = std::nextafter(boxes[i].max[1], kInfinity);
          break;
        default:
          boxes[i] = elsewhere[random() % elsewhere.size()];
      }
    }
    ASSERT_TRUE(testing::sameDeltaAs(sap, brute_force, boxes));
    if (last_was_moved_only && !sap.lastSearchWasMovedOnly()) ++full_after_moved_only;
    last_was_moved_only = sap.lastSearchWasMovedOnly();
    moved_only += last_was_moved_only ? 1 : 0;
  }
  EXPECT_GE(moved_only, 20) << "few moved boxes should not need the full search";
  EXPECT_GE(full_after_moved_only, 3);
  // And a frame where nothing moved changes nothing.
  sap.launch(boxes);
  const PairDelta none = sap.finish();
  EXPECT_TRUE(sap.lastSearchWasMovedOnly());
  EXPECT_TRUE(none.added.empty() && none.removed.empty());
}

TEST(CpuSapPairFinderTest, TheCallersChangedSlotsAreAllItCompares) {
  // As above, the caller naming the slots it wrote: the changed ones, some
  // unchanged ones and one twice.  A box changed but left out of the list
  // would be missed: the list is the whole truth, so it must be complete.
  std::vector<ObjectBounds> boxes = pile(3000, 0);
  const std::vector<ObjectBounds> elsewhere = pile(3000, 5);
  CpuSapPairFinder sap;
  CpuPairFinder brute_force;
  std::mt19937 random(12);
  int moved_only = 0;
  for (int frame = 0; frame < 30; ++frame) {
    SCOPED_TRACE("frame " + std::to_string(frame));
    std::vector<std::uint32_t> changed;
    const std::size_t moving = frame % 7 == 6 ? 400 : 30;
    for (std::size_t k = 0; k < moving; ++k) {
      const auto i = static_cast<std::uint32_t>(random() % boxes.size());
      if (random() % 5 == 0) {
        boxes[i] = ObjectBounds{};
      } else {
        boxes[i] = elsewhere[random() % elsewhere.size()];
      }
      changed.push_back(i);
    }
    changed.push_back(changed.front());                              // named twice
    changed.push_back(static_cast<std::uint32_t>(random() % 3000));  // maybe unchanged
    ASSERT_TRUE(testing::sameDeltaAs(sap, brute_force, boxes, changed));
    moved_only += sap.lastSearchWasMovedOnly() ? 1 : 0;
  }
  EXPECT_GE(moved_only, 20) << "few changed slots should not need the full search";
  const std::uint32_t past_the_end[] = {3000};
  EXPECT_THROW(sap.launchWithChanges(boxes, past_the_end), std::runtime_error);
}

TEST(CpuSapPairFinderTest, AnInvertedMovedBoxTakesTheFullSearch) {
  std::vector<ObjectBounds> boxes = pile(1000, 0);
  CpuSapPairFinder sap;
  CpuPairFinder brute_force;
  ASSERT_TRUE(testing::sameDeltaAs(sap, brute_force, boxes));
  boxes[17] = box(5, 5, 5, 4, 6, 6);
  ASSERT_TRUE(testing::sameDeltaAs(sap, brute_force, boxes));
  EXPECT_FALSE(sap.lastSearchWasMovedOnly());
  boxes[18] = box(1, 1, 1, 2, 2, 2);
  ASSERT_TRUE(testing::sameDeltaAs(sap, brute_force, boxes));
  EXPECT_FALSE(sap.lastSearchWasMovedOnly()) << "an inverted box is swept by the full search only";
}

TEST(CpuSapPairFinderTest, RejectsASecondLaunchBeforeTheFirstFinished) {
  CpuSapPairFinder finder;
  const std::vector<ObjectBounds> boxes(3, box(0, 0, 0, 1, 1, 1));
  finder.launch(boxes);
  EXPECT_THROW(finder.launch(boxes), std::runtime_error);
  EXPECT_EQ(finder.finish().added.size(), 3u);
}

TEST(SlabGridTest, SlabOfIsMonotoneAndClamped) {
  const sap::SlabGrid grid{-10.0f, 0.25f, 8};  // slabs of 4 m from -10 m
  EXPECT_EQ(grid.slabOf(-kInfinity), 0u);
  EXPECT_EQ(grid.slabOf(-10.0f), 0u);
  EXPECT_EQ(grid.slabOf(std::nextafter(-6.0f, -kInfinity)), 0u);
  EXPECT_EQ(grid.slabOf(-6.0f), 1u);
  EXPECT_EQ(grid.slabOf(21.9f), 7u);
  EXPECT_EQ(grid.slabOf(kInfinity), 7u);
  std::uint32_t last = 0;
  for (float v = -12.0f; v < 25.0f; v = std::nextafter(v + 0.01f, kInfinity)) {
    ASSERT_GE(grid.slabOf(v), last) << v;
    last = grid.slabOf(v);
  }
  EXPECT_EQ(sap::SlabGrid{}.slabOf(kInfinity), 0u);
}

TEST(PairSetTest, DeltaOfTwoSetsIsSortedAndExact) {
  // Rows arrive in any order; the delta comes out sorted by (a, b).
  const std::vector<std::uint64_t> before = {pairKey(5, 1), pairKey(0, 9), pairKey(2, 3),
                                             pairKey(0, 4), pairKey(7, 2)};
  const std::vector<std::uint64_t> after = {pairKey(2, 3),   pairKey(9, 0), pairKey(1, 0),
                                            pairKey(10, 11), pairKey(2, 8), pairKey(3, 0)};
  PairSet previous, current;
  const std::vector<std::span<const std::uint64_t>> old_batches = {before};
  previous.assign(10, old_batches);
  const std::vector<std::uint64_t> empty;
  const std::vector<std::span<const std::uint64_t>> new_batches = {after, empty};
  current.assign(12, new_batches);
  DeltaPart whole, low, high;
  appendDelta(previous, current, 0, 12, whole);
  EXPECT_TRUE(
      testing::samePairs(whole.added, std::vector<IndexPair>{{0, 1}, {0, 3}, {2, 8}, {10, 11}}));
  EXPECT_TRUE(testing::samePairs(whole.removed, std::vector<IndexPair>{{0, 4}, {1, 5}, {2, 7}}));
  // Two ranges of rows give the two halves of it.
  appendDelta(previous, current, 0, 2, low);
  appendDelta(previous, current, 2, 12, high);
  EXPECT_TRUE(testing::samePairs(low.added, std::vector<IndexPair>{{0, 1}, {0, 3}}));
  EXPECT_TRUE(testing::samePairs(high.removed, std::vector<IndexPair>{{2, 7}}));
}

TEST(PairSetTest, RowsComeOutSortedWhetherBuiltSeriallyOrInParallel) {
  std::mt19937 random(11);
  std::vector<std::uint64_t> keys;
  for (std::uint32_t a = 0; a < 3000; ++a) {
    for (std::uint32_t b = a + 1; b < 3000; b += 1 + static_cast<std::uint32_t>(random() % 400))
      keys.push_back(pairKey(b, a));
  }
  std::shuffle(keys.begin(), keys.end(), random);
  const std::span<const std::uint64_t> all(keys);
  const std::size_t third = keys.size() / 3;
  const std::vector<std::span<const std::uint64_t>> batches = {
      all.first(third), all.subspan(third, third), all.subspan(2 * third)};
  PairSet serial, parallel;
  serial.assign(3000, batches);
  parallel.assign(3000, batches, true);
  ASSERT_EQ(serial.size(), keys.size());
  ASSERT_EQ(parallel.size(), keys.size());
  for (std::uint32_t a = 0; a < 3000; ++a) {
    const std::span<const std::uint32_t> row = serial.partnersOf(a);
    ASSERT_TRUE(std::is_sorted(row.begin(), row.end())) << "row " << a;
    ASSERT_TRUE(std::equal(row.begin(), row.end(), parallel.partnersOf(a).begin(),
                           parallel.partnersOf(a).end()))
        << "row " << a;
  }
}

}  // namespace
}  // namespace overlap::finders
