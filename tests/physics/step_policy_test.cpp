// The step policy's rules, one by one, on plain numbers.
#include "physics/step_policy.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

namespace overlap::physics {
namespace {

constexpr double kFrame = 1.0 / 30.0;
constexpr double k50g = 50 * 9.798;

// Boxes of one size, `edge`, in walls `wall` thick.
FrameMotion motion(double speed, double gravity, double edge, double wall) {
  return FrameMotion{speed, gravity, kFrame, edge, edge, wall};
}

TEST(StepPolicy, ParsesTheOptionsAndRejectsTheRest) {
  EXPECT_EQ(parseSubsteps("auto"), kAutoSubsteps);
  EXPECT_EQ(parseSubsteps("8"), 8);
  for (const char* bad : {"0", "-1", "8x", "", "1001", "eight"}) {
    EXPECT_THROW(parseSubsteps(bad), std::invalid_argument) << bad;
  }
  EXPECT_EQ(parseCcdMode("off"), CcdMode::kOff);
  EXPECT_EQ(parseCcdMode("auto"), CcdMode::kAuto);
  EXPECT_EQ(parseCcdMode("all"), CcdMode::kAll);
  EXPECT_THROW(parseCcdMode("some"), std::invalid_argument);
  EXPECT_EQ(parseSleepMode("on"), SleepMode::kOn);
  EXPECT_THROW(parseSleepMode("yes"), std::invalid_argument);
  for (const CcdMode mode : {CcdMode::kOff, CcdMode::kAuto, CcdMode::kAll}) {
    EXPECT_EQ(parseCcdMode(ccdModeName(mode)), mode);
  }
}

TEST(StepPolicy, A50gPileAtRestKeepsTheStabilityFloor) {
  // g (T/K)^2 <= 0.03 x typical edge: a pile of 1 m boxes needs 5 substeps
  // at 50 g, whatever its smallest box (CCD on); at 1 g one step is stable.
  EXPECT_EQ(chooseSubsteps(motion(0, k50g, 1.0, 4.0), true), 5);
  EXPECT_EQ(chooseSubsteps(FrameMotion{0, k50g, kFrame, 0.1, 1.0, 8.0}, true), 5);
  EXPECT_EQ(chooseSubsteps(motion(0, 9.798, 1.0, 2.0), true), 1);
  // Larger boxes, the same gravity: a lower floor.
  EXPECT_LT(chooseSubsteps(motion(0, k50g, 4.0, 8.0), true), 5);
}

TEST(StepPolicy, FasterBoxesAndThinnerWallsNeedMoreSubstepsUpToTheCap) {
  int previous = 0;
  for (double speed = 0; speed <= 600; speed += 10) {
    const int k = chooseSubsteps(motion(speed, k50g, 1.0, 4.0), true);
    EXPECT_GE(k, previous) << speed;
    EXPECT_LE(k, SubstepRule{}.max_substeps);
    previous = k;
  }
  EXPECT_EQ(previous, SubstepRule{}.max_substeps);
  EXPECT_GT(chooseSubsteps(motion(150, k50g, 4.0, 2.5), true),
            chooseSubsteps(motion(150, k50g, 4.0, 8.0), true));
}

TEST(StepPolicy, EachSubstepMovesTheFastestBoxAtMostTheRulesShares) {
  const SubstepRule rule;
  for (const double speed : {5.0, 40.0, 120.0, 250.0}) {
    const FrameMotion m = motion(speed, k50g, 1.0, 6.0);
    const int k = chooseSubsteps(m, true, rule);
    if (k == rule.max_substeps) continue;
    const double per_substep = speedBound(speed, k50g, kFrame) * kFrame / k;
    EXPECT_LE(per_substep, rule.wall_share * m.wall_thickness + 1e-12) << speed;
    EXPECT_LE(per_substep, rule.motion_share * m.typical_edge + 1e-12) << speed;
  }
}

TEST(StepPolicy, WithoutCcdTheSmallestEdgeBoundsTheMotionToo) {
  const FrameMotion m{30, 9.798, kFrame, 0.1, 1.0, 8.0};
  EXPECT_GT(chooseSubsteps(m, false), chooseSubsteps(m, true));
}

TEST(StepPolicy, TheTypicalEdgeIsTheMedianBoxs) {
  EXPECT_EQ(typicalEdge(std::vector<double>{}), 0.0);
  EXPECT_EQ(typicalEdge(std::vector<double>{4.0, 0.1, 1.0}), 1.0);
  EXPECT_EQ(typicalEdge(std::vector<double>{0.2, 0.1, 3.0, 1.0, 2.0}), 1.0);
}

TEST(StepPolicy, CcdGoesToTheSmallFastBoxesOnly) {
  const std::vector<double> edges = {0.1, 0.1, 4.0, 4.0, 1.0};
  const std::vector<float> speeds = {200.0f, 0.0f, 200.0f, 0.0f, 10.0f};
  // 8 substeps at 1 g: 0.1 m at 200 m/s moves 0.83 m a substep (> 0.05), a 4 m box
  // too (< 2); a resting 0.1 m box moves g T^2/8 = 1.4 mm (< 0.05).
  const std::vector<char> chosen = chooseCcdBodies(CcdMode::kAuto, speeds, edges, 9.798, kFrame, 8);
  EXPECT_EQ(chosen, (std::vector<char>{1, 0, 0, 0, 0}));
  EXPECT_EQ(chooseCcdBodies(CcdMode::kAll, speeds, edges, 9.798, kFrame, 8),
            std::vector<char>(5, 1));
  EXPECT_EQ(chooseCcdBodies(CcdMode::kOff, speeds, edges, 9.798, kFrame, 8),
            std::vector<char>(5, 0));
  // More substeps, less motion per substep: fewer CCD bodies.
  EXPECT_EQ(chooseCcdBodies(CcdMode::kAuto, speeds, edges, 9.798, kFrame, 1000),
            std::vector<char>(5, 0));
}

TEST(StepPolicy, SleepIsTheDefaultOnlyWhereGravityIsFixed) {
  for (int scene = 1; scene <= 4; ++scene) {
    const SceneConfig config = SceneConfig::forScene(scene);
    EXPECT_EQ(sleepAllowed(config, SleepMode::kScene), scene <= 2) << scene;
    EXPECT_FALSE(sleepAllowed(config, SleepMode::kOff)) << scene;
  }
  EXPECT_TRUE(sleepAllowed(SceneConfig::forScene(1), SleepMode::kOn));
  EXPECT_THROW(sleepAllowed(SceneConfig::forScene(3), SleepMode::kOn), std::invalid_argument);
}

}  // namespace
}  // namespace overlap::physics
