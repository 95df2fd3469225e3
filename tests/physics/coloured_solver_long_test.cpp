// The coloured solver's thread-count invariance at the study's size: 3500
// boxes in every scene, on 1, 2, 3, 8 and 16 threads (label long), for 10
// frames: 30 took 370 s a scene in scenes 3 and 4 on 2 cores, most of CI's
// Release suite; the 150-box tests (coloured_solver_test.cpp) run longer.
#include <gtest/gtest.h>

#include "tests/physics/thread_count_states.h"

namespace overlap::physics {
namespace {

class SameStateForEveryThreadCountAt3500Boxes : public ::testing::TestWithParam<int> {};

TEST_P(SameStateForEveryThreadCountAt3500Boxes, WithCcdOnEveryBoxAndWithTheDefault) {
  EXPECT_EQ(testing::whereThreadCountsDiffer(GetParam(), 3500, 10), "") << "scene " << GetParam();
}

INSTANTIATE_TEST_SUITE_P(Scenes, SameStateForEveryThreadCountAt3500Boxes,
                         ::testing::Values(1, 2, 3, 4));

}  // namespace
}  // namespace overlap::physics
