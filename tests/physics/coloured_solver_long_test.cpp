// The coloured solver's thread-count invariance at the study's size: 3500
// boxes in every scene, on 1, 2, 3, 8 and 16 threads (label long), for 5
// frames: 10 took 70 s in scene 3 on 2 cores, the Release suite's longest
// test, and 30 took 370 s; the 250-box tests (coloured_solver_test.cpp) run
// 60 frames.
#include <gtest/gtest.h>

#include "tests/physics/thread_count_states.h"

namespace overlap::physics {
namespace {

class SameStateForEveryThreadCountAt3500Boxes : public ::testing::TestWithParam<int> {};

TEST_P(SameStateForEveryThreadCountAt3500Boxes, WithCcdOnEveryBoxAndWithTheDefault) {
  EXPECT_EQ(testing::whereThreadCountsDiffer(GetParam(), 3500, 5), "") << "scene " << GetParam();
}

INSTANTIATE_TEST_SUITE_P(Scenes, SameStateForEveryThreadCountAt3500Boxes,
                         ::testing::Values(1, 2, 3, 4));

}  // namespace
}  // namespace overlap::physics
