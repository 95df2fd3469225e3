// The step policy's rules, one by one, on plain numbers.
#include "physics/step_policy.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace overlap::physics {
namespace {

constexpr double kFrame = 1.0 / 30.0;
constexpr double k50g = 50 * 9.798;

// Boxes of one size, `edge`, in walls `wall` thick, the two fastest at `speed`.
FrameMotion motion(double speed, double gravity, double edge, double wall) {
  const TopSpeeds speeds{speed, speed};
  return FrameMotion{speeds, speeds, gravity, kFrame, edge, edge, wall};
}

TEST(StepPolicy, ParsesTheOptionsAndRejectsTheRest) {
  EXPECT_EQ(parseSubsteps("auto"), kAutoSubsteps);
  EXPECT_EQ(parseSubsteps("8"), 8);
  EXPECT_EQ(parseSubsteps("+8"), 8);  // as every whole-number option reads it
  for (const char* bad : {"0", "-1", "8x", "", "1001", "eight", "010", " 5", "5 ", "+-5"}) {
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
  for (const SolverMode mode : {SolverMode::kPile, SolverMode::kBullet}) {
    EXPECT_EQ(parseSolverMode(solverModeName(mode)), mode);
  }
  EXPECT_THROW(parseSolverMode("fast"), std::invalid_argument);
}

TEST(StepPolicy, A50gPileAtRestKeepsTheStabilityFloor) {
  // g (T/K)^2 <= 0.04 x typical edge: a pile of 1 m boxes needs 4 substeps
  // at 50 g (the measured threshold: it held at 4 and gave way at 3),
  // whatever its smallest box (CCD on); at 1 g one step holds.
  EXPECT_EQ(chooseSubsteps(motion(0, k50g, 1.0, 4.0), true), 4);
  EXPECT_EQ(chooseSubsteps(FrameMotion{{}, {}, k50g, kFrame, 0.1, 1.0, 8.0}, true), 4);
  EXPECT_EQ(chooseSubsteps(motion(0, 9.798, 1.0, 2.0), true), 1);
  // Larger boxes, the same gravity: a lower floor.
  EXPECT_LT(chooseSubsteps(motion(0, k50g, 4.0, 8.0), true), 4);
}

TEST(StepPolicy, TwoBoxesCloseAtTwiceTheFastestSpeedAndGravityAddsNothingBetweenThem) {
  // Scene 2's kicks at 1 g: a 7.6 m/s box may meet another coming the other
  // way, 0.51 m of closing in a frame: more than half a 1 m edge, so K = 2,
  // though the box alone moves 0.26 m (K = 1 against a wall).
  EXPECT_EQ(chooseSubsteps(motion(7.6, 9.798, 1.0, 2.69), true), 2);
  EXPECT_EQ(chooseSubsteps(motion(7.4, 9.798, 1.0, 2.69), true), 1);
  // Gravity adds g T to how fast a box closes on a wall, not on another box
  // (the pile floor switched off, to see the two bounds alone): at 50 g a
  // 5 m/s box closes 0.71 m a frame on a wall (K = 2) and at most 0.33 m
  // on a box; at 1 g a 12 m/s box 0.41 m on a wall, 0.80 m on a box (K = 2).
  SubstepRule no_floor;
  no_floor.fall_share = 1e9;
  EXPECT_EQ(chooseSubsteps(motion(5, k50g, 1.0, 100.0), true, no_floor), 2);
  EXPECT_EQ(chooseSubsteps(motion(5, 0.0, 1.0, 100.0), true, no_floor), 1);
  EXPECT_EQ(chooseSubsteps(motion(12, 9.798, 1.0, 100.0), true, no_floor), 2);
}

TEST(StepPolicy, TwoBoxesCloseAtMostAtTheirTwoFastestSpeedsSum) {
  // One box at 12 m/s among boxes at 2: they close at 14 m/s, 0.47 m a
  // frame (K = 1); two boxes at 12: 0.80 m (K = 2).
  SubstepRule no_floor;
  no_floor.fall_share = 1e9;
  const TopSpeeds one_fast{12, 2};
  const TopSpeeds two_fast{12, 12};
  EXPECT_EQ(chooseSubsteps({one_fast, one_fast, 9.798, kFrame, 1.0, 1.0, 100.0}, true, no_floor),
            1);
  EXPECT_EQ(chooseSubsteps({two_fast, two_fast, 9.798, kFrame, 1.0, 1.0, 100.0}, true, no_floor),
            2);
  TopSpeeds speeds;
  for (const double v : {3.0, 9.0, 1.0, 7.0, 9.0, 2.0}) speeds.add(v);
  EXPECT_EQ(speeds.fastest, 9.0);
  EXPECT_EQ(speeds.second, 9.0);
}

TEST(StepPolicy, WithCcdTheSmallFastBoxesAreSweptNotSubstepped) {
  // Scene 4: 0.1 m boxes squeezed out of the pile at 60 m/s while the boxes
  // of the typical edge move at 10.  With CCD their sweep bounds them;
  // without, every box is substepped for them.
  const TopSpeeds all{60, 60};
  const TopSpeeds typical{10, 10};
  const FrameMotion m{all, typical, 9.798, kFrame, 0.1, 1.0, 8.0};
  EXPECT_EQ(chooseSubsteps(m, true), 2);  // 2 x 10 m/s closing: 0.67 m a frame
  EXPECT_EQ(chooseSubsteps(m, false), SubstepRule{}.max_substeps);
  // The wall's bound still reads every box: 60 m/s through a 0.3 m wall.
  const FrameMotion thin{all, typical, 9.798, kFrame, 0.1, 1.0, 0.3};
  EXPECT_GT(chooseSubsteps(thin, true), 2);
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

TEST(StepPolicy, EachSubstepClosesAtMostTheRulesShares) {
  const SubstepRule rule;
  for (const double gravity : {9.798, k50g}) {
    for (const double speed : {5.0, 40.0, 120.0, 250.0}) {
      const FrameMotion m = motion(speed, gravity, 1.0, 6.0);
      const int k = chooseSubsteps(m, true, rule);
      if (k == rule.max_substeps) continue;
      const double wall_closing = speedBound(speed, gravity, kFrame) * kFrame / k;
      const double box_closing = 2 * speed * kFrame / k;
      EXPECT_LE(wall_closing, rule.wall_share * m.wall_thickness + 1e-12) << speed;
      EXPECT_LE(wall_closing, rule.motion_share * m.typical_edge + 1e-12) << speed;
      EXPECT_LE(box_closing, rule.motion_share * m.typical_edge + 1e-12) << speed;
      // And K is the least that does: one fewer breaks a bound (or the floor).
      if (k > 1) {
        const bool floor =
            gravity * (kFrame / (k - 1)) * (kFrame / (k - 1)) > rule.fall_share * m.typical_edge;
        EXPECT_TRUE(floor || 2 * speed * kFrame / (k - 1) > rule.motion_share * m.typical_edge ||
                    speedBound(speed, gravity, kFrame) * kFrame / (k - 1) >
                        rule.motion_share * m.typical_edge)
            << speed;
      }
    }
  }
}

TEST(StepPolicy, ThePileSolverWarmStartsFullyAndCorrectsOverlapInTheVelocitySolve) {
  const SolverSettings pile = solverSettings(SolverMode::kPile);
  const SolverSettings bullet = solverSettings(SolverMode::kBullet);
  EXPECT_EQ(pile.iterations, 8);
  EXPECT_EQ(bullet.iterations, 10);
  EXPECT_EQ(pile.warmstarting_factor, 1.0);
  EXPECT_FALSE(pile.split_impulse);
  EXPECT_EQ(bullet.warmstarting_factor, 0.85);  // Bullet 3.24's btContactSolverInfo
  EXPECT_TRUE(bullet.split_impulse);
}

TEST(StepPolicy, WithoutCcdTheSmallestEdgeBoundsTheMotionToo) {
  const FrameMotion m{{30, 30}, {30, 30}, 9.798, kFrame, 0.1, 1.0, 8.0};
  EXPECT_GT(chooseSubsteps(m, false), chooseSubsteps(m, true));
}

TEST(StepPolicy, ALargeBoxMovesInItsOwnEdges) {
  // A 4 m box at 100 m/s closes by as many of its edges per substep as a
  // typical 1 m box at 25; a typical box is read as it is.
  EXPECT_DOUBLE_EQ(inTypicalEdges(100, 4.0, 1.0), 25.0);
  EXPECT_DOUBLE_EQ(inTypicalEdges(30, 1.0, 1.0), 30.0);
  // So a frame whose fastest typical-or-larger box is a 4 m one at 100 m/s
  // (scene 4) needs the K of 25 m/s boxes, not of 100 m/s ones.
  TopSpeeds large;
  large.add(inTypicalEdges(100, 4.0, 1.0));
  large.add(inTypicalEdges(90, 3.5, 1.0));
  const TopSpeeds all{100, 90};
  const FrameMotion m{all, large, k50g, kFrame, 0.1, 1.0, 8.0};
  const FrameMotion as_typical{all, all, k50g, kFrame, 0.1, 1.0, 8.0};
  EXPECT_EQ(chooseSubsteps(m, true), 4);  // the pile's floor
  EXPECT_GT(chooseSubsteps(as_typical, true), 8);
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
