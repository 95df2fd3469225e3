// The coloured solver's thread-count invariance at the study's size: 3500
// boxes in every scene, on 1, 2, 3, 8 and 16 threads (label long), for 5
// frames: 10 took 70 s in scene 3 on 2 cores, the Release suite's longest
// test, and 30 took 370 s.  And the busy scenes, 3 and 4, at the 250 boxes
// and 60 frames of coloured_solver_test.cpp's scenes 1 and 2: 21 and 15 s on
// 2 cores, the fast unit tests' longest (and 39 and 29 s under ASan).
#include <gtest/gtest.h>

#include <string>

#include "tests/physics/thread_count_states.h"

namespace overlap::physics {
namespace {

class SameStateForEveryThreadCountAt3500Boxes : public ::testing::TestWithParam<int> {};

TEST_P(SameStateForEveryThreadCountAt3500Boxes, WithCcdOnEveryBoxAndWithTheDefault) {
  EXPECT_EQ(testing::whereThreadCountsDiffer(GetParam(), 3500, 5), "") << "scene " << GetParam();
}

INSTANTIATE_TEST_SUITE_P(Scenes, SameStateForEveryThreadCountAt3500Boxes,
                         ::testing::Values(1, 2, 3, 4));

class SameStateForEveryThreadCountInTheBusyScenes : public ::testing::TestWithParam<int> {};

TEST_P(SameStateForEveryThreadCountInTheBusyScenes, WithCcdOnEveryBoxAndWithTheDefault) {
  EXPECT_EQ(testing::whereThreadCountsDiffer(GetParam(), 250, 60), "") << "scene " << GetParam();
}

INSTANTIATE_TEST_SUITE_P(Scenes, SameStateForEveryThreadCountInTheBusyScenes,
                         ::testing::Values(3, 4), [](const ::testing::TestParamInfo<int>& info) {
                           return "scene" + std::to_string(info.param);
                         });

}  // namespace
}  // namespace overlap::physics
