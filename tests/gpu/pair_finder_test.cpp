// The pair finders against the oracle, frame after frame, and the GPU
// finders against cpubf.  The GPU cases skip, saying why, without a device.
#include "gpu/pair_finder.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "gpu/cpu/cpu_pair_finder.h"
#include "tests/gpu/pair_test_support.h"

namespace overlap::finders {
namespace {

using testing::box;
using testing::BoxSet;

class PairFinderTest : public ::testing::TestWithParam<std::string_view> {
 protected:
  void SetUp() override {
    std::string why;
    if (testing::isGpuFinder(GetParam()) && !cudaDeviceAvailable(&why)) {
      GTEST_SKIP() << "no CUDA device: " << why;
    }
    finder_ = makePairFinder(GetParam());
  }

  std::unique_ptr<PairFinder> finder_;
};

TEST_P(PairFinderTest, MatchesOracleFrameAfterFrame) {
  for (const BoxSet set : testing::kAllBoxSets) {
    for (const std::uint32_t n : {0u, 1u, 2u, 31u, 32u, 33u, 1023u, 1024u, 1025u, 3500u}) {
      // Every pair of 3500 identical boxes is 6 million pairs per list: the
      // large-change path is exercised at 1025 already (ManyChangesAtOnce).
      if (set == BoxSet::kIdentical && n > 1025) continue;
      SCOPED_TRACE(testing::boxSetName(set) + ", n = " + std::to_string(n));
      auto finder = makePairFinder(GetParam());
      std::vector<IndexPair> pairs;
      for (int frame = 0; frame < 4; ++frame) {
        SCOPED_TRACE("frame " + std::to_string(frame));
        testing::expectFrameMatchesOracle(*finder, testing::makeBoxes(set, n, frame), pairs);
      }
    }
  }
}

TEST_P(PairFinderTest, AppliesCollisionFilters) {
  constexpr std::int32_t kStatic = 2;
  constexpr std::int32_t kAll = -1;
  // Six boxes that all overlap; only the filters decide.
  const std::vector<ObjectBounds> boxes = {
      box(0, 0, 0, 1, 1, 1, 1, kAll),                  // 0 dynamic
      box(0, 0, 0, 1, 1, 1, kStatic, kAll ^ kStatic),  // 1 static
      box(0, 0, 0, 1, 1, 1, kStatic, kAll ^ kStatic),  // 2 static
      box(0, 0, 0, 1, 1, 1, 4, kStatic),               // 3 wants statics only
      box(0, 0, 0, 1, 1, 1, 0, 0),                     // 4 unused slot
      box(0, 0, 0, 1, 1, 1, 1, kAll),                  // 5 dynamic
  };
  finder_->launch(boxes);
  const PairDelta delta = finder_->finish();
  const std::vector<IndexPair> expected = {{0, 1}, {0, 2}, {0, 5}, {1, 3}, {1, 5}, {2, 3}, {2, 5}};
  EXPECT_TRUE(testing::samePairs(delta.added, expected));
  EXPECT_TRUE(delta.removed.empty());
}

TEST_P(PairFinderTest, SlotCountGrowsMidRun) {
  std::vector<IndexPair> pairs;
  std::vector<ObjectBounds> boxes;
  int frame = 0;
  for (const std::uint32_t n : {5u, 33u, 33u, 100u, 1100u, 1101u}) {
    SCOPED_TRACE("n = " + std::to_string(n));
    const std::vector<ObjectBounds> grown = testing::makeBoxes(BoxSet::kRandom, n, frame++);
    // Old slots keep moving; new slots arrive on top of old ones.
    for (std::size_t i = 0; i < boxes.size(); ++i) boxes[i] = grown[i];
    for (std::size_t i = boxes.size(); i < n; ++i)
      boxes.push_back(boxes.empty() ? grown[i] : boxes[i % boxes.size()]);
    testing::expectFrameMatchesOracle(*finder_, boxes, pairs);
  }
}

TEST_P(PairFinderTest, ManyChangesAtOnce) {
  // 1100 identical boxes: 604,450 pairs appear in one frame and vanish in the
  // next, far more than a change list holds at first.
  std::vector<ObjectBounds> boxes(1100, box(0, 0, 0, 1, 1, 1));
  std::vector<IndexPair> pairs;
  testing::expectFrameMatchesOracle(*finder_, boxes, pairs);
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const float x = 2.0f * static_cast<float>(i);
    boxes[i] = box(x, 0, 0, x + 1, 1, 1);
  }
  testing::expectFrameMatchesOracle(*finder_, boxes, pairs);
  EXPECT_TRUE(pairs.empty());
}

// Slots 0.. in clusters of identical boxes (every pair inside a cluster
// overlaps, none across), the other slots apart: sum of k (k - 1) / 2 pairs.
std::vector<ObjectBounds> clusters(std::uint32_t n, std::initializer_list<std::uint32_t> sizes) {
  std::vector<ObjectBounds> boxes;
  float x = 0;
  for (const std::uint32_t size : sizes) {
    boxes.insert(boxes.end(), size, box(x, 0, 0, x + 1, 1, 1));
    x += 10;
  }
  while (boxes.size() < n) {
    const float far = 1000.0f + 3.0f * static_cast<float>(boxes.size());
    boxes.push_back(box(far, 0, 0, far + 1, 1, 1));
  }
  return boxes;
}

TEST_P(PairFinderTest, ChangeCountsAroundTheChangeListCapacities) {
  // gpubf copies the first 4096 changes of each list back speculatively,
  // fetches whole lists above that, holds 16384 changes per list at first and
  // collects them again into grown lists above that (32768 after the first
  // growth).  Each count is added in one frame and removed in the next.
  constexpr std::uint32_t kSlots = 300;
  const struct {
    std::size_t changes;
    std::initializer_list<std::uint32_t> sizes;
  } frames[] = {{4096, {91, 2}},          {4097, {91, 2, 2}}, {16384, {181, 14, 3}},
                {16385, {181, 14, 3, 2}}, {39903, {283}},     {4095, {91}}};
  std::vector<IndexPair> pairs;
  const std::vector<ObjectBounds> apart = clusters(kSlots, {});
  for (const auto& frame : frames) {
    SCOPED_TRACE(std::to_string(frame.changes) + " changes");
    const std::vector<ObjectBounds> boxes = clusters(kSlots, frame.sizes);
    ASSERT_EQ(testing::oraclePairs(boxes).size(), frame.changes);
    testing::expectFrameMatchesOracle(*finder_, boxes, pairs);
    testing::expectFrameMatchesOracle(*finder_, apart, pairs);
    EXPECT_TRUE(pairs.empty());
  }
}

TEST_P(PairFinderTest, RejectsAShrinkingSlotCount) {
  const std::vector<ObjectBounds> boxes(10, box(0, 0, 0, 1, 1, 1));
  finder_->launch(boxes);
  finder_->finish();
  EXPECT_THROW(finder_->launch(std::span(boxes).first(9)), std::runtime_error);
}

TEST_P(PairFinderTest, RejectsFinishWithoutLaunch) {
  EXPECT_THROW(finder_->finish(), std::runtime_error);
}

TEST_P(PairFinderTest, RefusesCallsOutOfOrderByNameAndKeepsTheFrame) {
  const std::vector<ObjectBounds> boxes = testing::makeBoxes(BoxSet::kRandom, 100, 0);
  finder_->launch(boxes);
  try {
    finder_->launch(boxes);
    ADD_FAILURE() << "a second launch() was accepted";
  } catch (const std::runtime_error& error) {
    EXPECT_EQ(std::string(error.what()),
              std::string(GetParam()) + ": launch() called twice without finish()");
  }
  EXPECT_THROW(finder_->launchWithChanges(boxes, {}), std::runtime_error);
  EXPECT_THROW(finder_->stagingFor(boxes.size()), std::runtime_error);
  const PairDelta delta = finder_->finish();
  EXPECT_TRUE(testing::samePairs(delta.added, testing::oraclePairs(boxes)));
  EXPECT_THROW(finder_->finish(), std::runtime_error);
}

INSTANTIATE_TEST_SUITE_P(AllFinders, PairFinderTest, ::testing::ValuesIn(testing::finderNames()),
                         testing::finderTestName);

// The GPU finders give exactly cpubf's deltas on a long random run.
class GpuAgreesWithCpuTest : public PairFinderTest {};

TEST_P(GpuAgreesWithCpuTest, SameDeltasAsCpubf) {
  CpuPairFinder cpu;
  for (int frame = 0; frame < 20; ++frame) {
    const std::vector<ObjectBounds> boxes = testing::makeBoxes(BoxSet::kRandom, 2000, frame);
    cpu.launch(boxes);
    finder_->launch(boxes);
    const PairDelta expected = cpu.finish();
    const PairDelta actual = finder_->finish();
    ASSERT_TRUE(testing::samePairs(actual.added, expected.added)) << "frame " << frame;
    ASSERT_TRUE(testing::samePairs(actual.removed, expected.removed)) << "frame " << frame;
  }
}

INSTANTIATE_TEST_SUITE_P(GpuFinders, GpuAgreesWithCpuTest,
                         ::testing::ValuesIn(testing::finderNames(true)), testing::finderTestName);

TEST(CpuPairFinderTest, ThreadCountDoesNotChangeTheAnswer) {
  CpuPairFinder one(1);
  CpuPairFinder two(2);
  CpuPairFinder all(0);
  for (int frame = 0; frame < 5; ++frame) {
    const std::vector<ObjectBounds> boxes = testing::makeBoxes(BoxSet::kRandom, 1500, frame);
    for (PairFinder* finder : {static_cast<PairFinder*>(&one), static_cast<PairFinder*>(&two),
                               static_cast<PairFinder*>(&all)}) {
      finder->launch(boxes);
    }
    const PairDelta reference = one.finish();
    for (CpuPairFinder* finder : {&two, &all}) {
      const PairDelta delta = finder->finish();
      EXPECT_TRUE(testing::samePairs(delta.added, reference.added));
      EXPECT_TRUE(testing::samePairs(delta.removed, reference.removed));
    }
  }
}

TEST(CpuPairFinderTest, ReportNoDeviceWork) {
  for (const std::string_view name : testing::finderNames(false)) {
    SCOPED_TRACE(name);
    const auto finder = makePairFinder(name);
    for (int frame = 0; frame < 2; ++frame) {
      finder->launch(testing::makeBoxes(BoxSet::kRandom, 100, frame));
      EXPECT_FALSE(finder->finish().added.empty() && frame == 0);
    }
    const DeviceWork work = finder->lastStats().device;
    EXPECT_EQ(work.upload_ms + work.kernels_ms + work.download_ms, 0.0);
    EXPECT_EQ(work.bytes_to_device + work.bytes_from_device + work.api_calls +
                  work.host_bytes_copied + work.host_entries_sorted,
              0u);
  }
}

TEST(CheckedSlotCountTest, AcceptsGrowthAndRejectsShrinkingOrOversizedCountsByName) {
  constexpr std::size_t kMaxSlots = std::numeric_limits<std::uint32_t>::max();
  EXPECT_EQ(checkedSlotCount("cpubf", 3, 3), 3u);
  EXPECT_EQ(checkedSlotCount("cpubf", 3, 10), 10u);
  EXPECT_EQ(checkedSlotCount("cpubf", 0, kMaxSlots), kMaxSlots);
  try {
    checkedSlotCount("gpubf", 10, 9);
    ADD_FAILURE() << "a shrinking slot count was accepted";
  } catch (const std::runtime_error& error) {
    EXPECT_STREQ(error.what(), "gpubf: slot count shrank from 10 to 9");
  }
  try {
    checkedSlotCount("gpubf-paper", 0, kMaxSlots + 1);
    ADD_FAILURE() << "2^32 slots were accepted";
  } catch (const std::runtime_error& error) {
    EXPECT_STREQ(error.what(), "gpubf-paper: 4294967296 slots do not fit 32-bit slot indices");
  }
}

TEST(MakePairFinderTest, MakesEachRowsFinderByNameAndDeviceOnesOnlyWithADevice) {
  std::string why;
  const bool device = cudaDeviceAvailable(&why);
  EXPECT_TRUE(device || !why.empty());
  for (const PairFinderRow& row : pairFinderTable()) {
    SCOPED_TRACE(row.name);
    if (row.needs_device && !device) {
      EXPECT_THROW(makePairFinder(row.name), std::runtime_error);
    } else {
      EXPECT_EQ(makePairFinder(row.name)->name(), row.name);
    }
  }
  EXPECT_THROW(makePairFinder("no-such-finder"), std::invalid_argument);
}

}  // namespace
}  // namespace overlap::finders
