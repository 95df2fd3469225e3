// BackgroundPairFinder: cpubf on its own worker gives cpubf's answers, hands
// the worker's errors back to the caller, and reports when its search began.
#include "gpu/background_pair_finder.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <vector>

#include "gpu/cpu_pair_finder.h"
#include "gpu/cpu_sap_pair_finder.h"
#include "tests/gpu/pair_test_support.h"

namespace overlap::gpu {
namespace {

using testing::box;
using testing::BoxSet;

TEST(BackgroundPairFinderTest, GivesCpubfsDeltasFrameAfterFrame) {
  BackgroundPairFinder background(std::make_unique<CpuPairFinder>());
  CpuPairFinder reference;
  EXPECT_EQ(background.name(), "cpubf");
  for (int frame = 0; frame < 6; ++frame) {
    std::vector<ObjectBounds> boxes = testing::makeBoxes(BoxSet::kRandom, 1025, frame);
    background.launch(boxes);
    // launch() copied the boxes: changing them now must not change the answer.
    const std::vector<ObjectBounds> launched = boxes;
    for (ObjectBounds& b : boxes) b = box(1e6f, 1e6f, 1e6f, 1e6f, 1e6f, 1e6f);
    reference.launch(launched);
    const PairDelta expected = reference.finish();
    const PairDelta actual = background.finish();
    ASSERT_TRUE(testing::samePairs(actual.added, expected.added)) << "frame " << frame;
    ASSERT_TRUE(testing::samePairs(actual.removed, expected.removed)) << "frame " << frame;
  }
}

TEST(BackgroundPairFinderTest, CopiesOnlyTheChangedSlotsAndStaysExact) {
  BackgroundPairFinder background(std::make_unique<CpuSapPairFinder>());
  CpuPairFinder reference;
  std::vector<ObjectBounds> boxes = testing::makeBoxes(BoxSet::kRandom, 1025, 0);
  const std::vector<ObjectBounds> elsewhere = testing::makeBoxes(BoxSet::kRandom, 1025, 1);
  ASSERT_TRUE(testing::sameDeltaAs(background, reference, boxes));
  for (std::uint32_t frame = 1; frame < 8; ++frame) {
    std::vector<std::uint32_t> changed;
    for (std::uint32_t i = frame; i < boxes.size(); i += 97) {
      boxes[i] = elsewhere[(i * 7 + frame) % elsewhere.size()];
      changed.push_back(i);
    }
    ASSERT_TRUE(testing::sameDeltaAs(background, reference, boxes, changed)) << "frame " << frame;
  }
  const std::uint32_t past_the_end[] = {1025};
  EXPECT_THROW(background.launchWithChanges(boxes, past_the_end), std::runtime_error);
}

TEST(BackgroundPairFinderTest, RethrowsTheWorkersErrorFromFinishAndGoesOn) {
  BackgroundPairFinder background(std::make_unique<CpuPairFinder>());
  const std::vector<ObjectBounds> boxes(10, box(0, 0, 0, 1, 1, 1));
  background.launch(boxes);
  EXPECT_EQ(background.finish().added.size(), 45u);
  background.launch(std::span(boxes).first(9));  // the worker's cpubf rejects the shrink
  EXPECT_THROW(background.finish(), std::runtime_error);
  background.launch(boxes);  // the same slots again: nothing changed since the last answer
  const PairDelta delta = background.finish();
  EXPECT_TRUE(delta.added.empty());
  EXPECT_TRUE(delta.removed.empty());
}

TEST(BackgroundPairFinderTest, RejectsLaunchTwiceAndFinishWithoutLaunch) {
  BackgroundPairFinder background(std::make_unique<CpuPairFinder>());
  EXPECT_THROW(background.finish(), std::runtime_error);
  const std::vector<ObjectBounds> boxes(4, box(0, 0, 0, 1, 1, 1));
  background.launch(boxes);
  EXPECT_THROW(background.launch(boxes), std::runtime_error);
  EXPECT_EQ(background.finish().added.size(), 6u);
}

// The search starts on the worker after launch() and before finish() returns,
// so its delay lies between zero and the whole launch-to-finish interval.
TEST(BackgroundPairFinderTest, SearchDelayLiesWithinLaunchToFinish) {
  BackgroundPairFinder background(std::make_unique<CpuPairFinder>());
  const std::vector<ObjectBounds> boxes = testing::makeBoxes(BoxSet::kRandom, 2000, 0);
  for (int frame = 0; frame < 3; ++frame) {
    const auto launched = std::chrono::steady_clock::now();
    background.launch(boxes);
    background.finish();
    const double interval_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - launched)
            .count();
    EXPECT_GE(background.lastSearchDelayMs(), 0.0);
    EXPECT_LE(background.lastSearchDelayMs() + background.lastSearchMs(), interval_ms);
  }
}

}  // namespace
}  // namespace overlap::gpu
