// The shared per-pair logic: exact pair numbering, the inclusive overlap test,
// the filter test and the bit algebra of added and removed pairs.
#include "gpu/pairs/pair_logic.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>

#include "tests/gpu/pair_test_support.h"

namespace overlap::finders {
namespace {

using pair_logic::addedBits;
using pair_logic::boxesOverlap;
using pair_logic::filtersAccept;
using pair_logic::objectsPair;
using pair_logic::pairAt;
using pair_logic::pairIndex;
using pair_logic::pairsBelow;
using pair_logic::removedBits;
using pair_logic::wordCount;
using testing::box;

TEST(PairLogicTest, PairIndexRoundTripsExhaustivelyForSmallSlotCounts) {
  constexpr std::uint32_t kSlots = 2000;
  std::uint64_t expected_index = 0;
  for (std::uint32_t b = 1; b < kSlots; ++b) {
    ASSERT_EQ(pairsBelow(b), expected_index);
    for (std::uint32_t a = 0; a < b; ++a, ++expected_index) {
      ASSERT_EQ(pairIndex(a, b), expected_index);
      ASSERT_EQ(pairAt(expected_index), (IndexPair{a, b})) << "p = " << expected_index;
    }
  }
  EXPECT_EQ(expected_index, pairsBelow(kSlots));
}

TEST(PairLogicTest, PairCountIsExactUpToTheLargestSlot) {
  const std::uint64_t rows[] = {
      2,         3, 1ull << 21, (1ull << 26) + 1, (1ull << 31) - 1, 1ull << 31, (1ull << 32) - 1,
      1ull << 32};
  for (const std::uint64_t b : rows) {
    __extension__ using Wide = unsigned __int128;  // wide enough for b (b - 1) itself
    const Wide exact = static_cast<Wide>(b) * (b - 1) / 2;
    EXPECT_TRUE(static_cast<Wide>(pairsBelow(b)) == exact) << "b = " << b;
  }
}

TEST(PairLogicTest, PairIndexRoundTripsAtSixtyFourBitBoundaries) {
  constexpr std::uint64_t kLargest = std::numeric_limits<std::uint32_t>::max();
  const std::uint64_t rows[] = {1ull << 21,       (1ull << 21) + 1, (1ull << 26) - 1, 1ull << 26,
                                (1ull << 31) - 1, 1ull << 31,       (1ull << 31) + 1, 3037000499ull,
                                kLargest - 1,     kLargest};
  for (const std::uint64_t row : rows) {
    const auto b = static_cast<std::uint32_t>(row);
    for (const std::uint32_t a : {0u, 1u, b / 2, b - 2, b - 1}) {
      const std::uint64_t p = pairIndex(a, b);
      EXPECT_EQ(pairAt(p), (IndexPair{a, b})) << "p = " << p;
    }
    // The last pair of the previous row sits just before this row's first.
    EXPECT_EQ(pairAt(pairsBelow(b) - 1), (IndexPair{b - 2, b - 1})) << "b = " << b;
  }
  EXPECT_EQ(
      pairAt(pairsBelow(kLargest + 1) - 1),
      (IndexPair{static_cast<std::uint32_t>(kLargest - 1), static_cast<std::uint32_t>(kLargest)}));
}

TEST(PairLogicTest, PairAtIsExactBeyondDoublePrecision) {
  const std::uint64_t centres[] = {1ull << 53, 1ull << 62, (1ull << 62) + (1ull << 61)};
  for (const std::uint64_t centre : centres) {
    for (std::uint64_t p = centre - 64; p != centre + 64; ++p) {
      const IndexPair pair = pairAt(p);
      ASSERT_LT(pair.a, pair.b);
      ASSERT_EQ(pairIndex(pair.a, pair.b), p);
    }
  }
}

// The kernels' decode: exact at the first and last pair of rows sampled over
// the whole range and at the top, and its FP32 estimate at most one row off,
// so each lane's correction loop runs at most once.
TEST(PairLogicTest, PairAtIsExactAtRowBoundariesAndItsEstimateWithinOneRow) {
  constexpr std::uint64_t kLargest = std::numeric_limits<std::uint32_t>::max();
  std::mt19937_64 random(11);
  std::vector<std::uint64_t> rows;
  for (int i = 0; i < 200000; ++i) rows.push_back(2 + random() % (kLargest - 1));
  for (std::uint64_t b = 2; b < 5000; ++b) rows.push_back(b);
  for (std::uint64_t b = kLargest - 5000; b <= kLargest; ++b) rows.push_back(b);
  for (const std::uint64_t row : rows) {
    const auto b = static_cast<std::uint32_t>(row);
    const std::uint64_t first = pairsBelow(b);
    for (const std::uint64_t p : {first, first + b - 1, first + random() % b}) {
      const IndexPair expected{static_cast<std::uint32_t>(p - first), b};
      ASSERT_EQ(pairAt(p), expected) << "p = " << p;
      const std::uint64_t estimate = pair_logic::rowEstimate(p);
      ASSERT_LE(std::max(estimate, row) - std::min(estimate, row), 1u) << "p = " << p;
    }
  }
}

TEST(PairLogicTest, TouchingBoxesOverlap) {
  const ObjectBounds unit = box(0, 0, 0, 1, 1, 1);
  EXPECT_TRUE(boxesOverlap(unit, box(1, 0, 0, 2, 1, 1)));  // face
  EXPECT_TRUE(boxesOverlap(unit, box(1, 1, 0, 2, 2, 1)));  // edge
  EXPECT_TRUE(boxesOverlap(unit, box(1, 1, 1, 2, 2, 2)));  // corner
  EXPECT_TRUE(boxesOverlap(unit, box(-1, -1, -1, 0, 0, 0)));
  EXPECT_TRUE(boxesOverlap(unit, unit));
}

TEST(PairLogicTest, BoxesOneUlpApartDoNotOverlap) {
  const ObjectBounds unit = box(0, 0, 0, 1, 1, 1);
  const float just_past = std::nextafter(1.0f, 2.0f);
  EXPECT_FALSE(boxesOverlap(unit, box(just_past, 0, 0, 2, 1, 1)));
  EXPECT_FALSE(boxesOverlap(unit, box(0, just_past, 0, 1, 2, 1)));
  EXPECT_FALSE(boxesOverlap(unit, box(0, 0, just_past, 1, 1, 2)));
  const float far = 1.0e6f;
  EXPECT_FALSE(
      boxesOverlap(box(far, far, far, far + 1, far + 1, far + 1),
                   box(std::nextafter(far + 1, 2e6f), far, far, far + 2, far + 1, far + 1)));
}

TEST(PairLogicTest, DegenerateBoxesOverlapWhereTheyMeet) {
  const ObjectBounds point = box(1, 1, 1, 1, 1, 1);
  EXPECT_TRUE(boxesOverlap(point, box(0, 0, 0, 1, 1, 1)));  // a corner
  EXPECT_TRUE(boxesOverlap(point, point));
  EXPECT_TRUE(boxesOverlap(box(0, 0.5f, 0, 2, 0.5f, 2), box(1, 0, 1, 1, 1, 1)));  // flat, segment
  EXPECT_FALSE(boxesOverlap(point, box(0, 0, 0, 1, 1, std::nextafter(1.0f, 0.0f))));
}

TEST(PairLogicTest, NanNeverOverlaps) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FALSE(boxesOverlap(box(nan, 0, 0, 1, 1, 1), box(0, 0, 0, 1, 1, 1)));
  EXPECT_FALSE(boxesOverlap(box(0, 0, 0, 1, 1, 1), box(0, 0, 0, 1, nan, 1)));
}

TEST(PairLogicTest, FiltersMustAcceptEachOther) {
  constexpr std::int32_t kStatic = 2;  // btBroadphaseProxy::StaticFilter
  constexpr std::int32_t kDefault = 1;
  constexpr std::int32_t kAll = -1;
  EXPECT_TRUE(filtersAccept(kDefault, kAll, kDefault, kAll));
  EXPECT_TRUE(filtersAccept(kDefault, kAll, kStatic, kAll ^ kStatic));
  EXPECT_FALSE(filtersAccept(kStatic, kAll ^ kStatic, kStatic, kAll ^ kStatic));
  EXPECT_FALSE(filtersAccept(kDefault, kAll, kDefault, kStatic));  // one-way is not enough
  EXPECT_FALSE(filtersAccept(0, 0, kDefault, kAll));               // an unused slot
}

TEST(PairLogicTest, ChangedBitsSplitIntoAddedAndRemoved) {
  const std::uint32_t previous = 0b1100u;
  const std::uint32_t current = 0b1010u;
  EXPECT_EQ(addedBits(previous, current), 0b0010u);
  EXPECT_EQ(removedBits(previous, current), 0b0100u);
  EXPECT_EQ(addedBits(current, current) | removedBits(current, current), 0u);
  EXPECT_EQ(wordCount(0), 0u);
  EXPECT_EQ(wordCount(1), 1u);
  EXPECT_EQ(wordCount(32), 1u);
  EXPECT_EQ(wordCount(33), 2u);
}

TEST(PairLogicTest, ObjectsPairAgreesWithTheOracle) {
  for (const testing::BoxSet set : testing::kAllBoxSets) {
    for (int frame = 0; frame < 3; ++frame) {
      const std::vector<ObjectBounds> boxes = testing::makeBoxes(set, 300, frame);
      for (std::size_t b = 0; b < boxes.size(); ++b) {
        for (std::size_t a = 0; a < b; ++a) {
          ASSERT_EQ(objectsPair(boxes[a], boxes[b]), testing::oracleOverlap(boxes[a], boxes[b]))
              << testing::boxSetName(set) << " frame " << frame << " pair (" << a << ", " << b
              << ")";
        }
      }
    }
  }
}

}  // namespace
}  // namespace overlap::finders
