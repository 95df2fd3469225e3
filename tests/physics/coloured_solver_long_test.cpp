// The coloured solver's thread-count invariance at the study's size: 3500
// boxes in every scene, on 1, 2, 3, 8 and 16 threads (label long).
#include <gtest/gtest.h>

#include "tests/physics/thread_count_states.h"

namespace overlap::physics {
namespace {

class SameStateForEveryThreadCountAt3500Boxes : public ::testing::TestWithParam<int> {};

TEST_P(SameStateForEveryThreadCountAt3500Boxes, WithCcdOnEveryBoxAndWithTheDefault) {
  const int scene = GetParam();
  for (const CcdMode ccd : {CcdMode::kAll, CcdMode::kAuto}) {
    EXPECT_EQ(testing::threadCountsThatDiffer(scene, 3500, 30, ccd), "")
        << "scene " << scene << ", ccd " << ccdModeName(ccd);
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, SameStateForEveryThreadCountAt3500Boxes,
                         ::testing::Values(1, 2, 3, 4));

}  // namespace
}  // namespace overlap::physics
