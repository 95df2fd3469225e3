// The simulation at its limits: scenes 3 and 4 (50 g) at the largest box
// count the suite can afford and over a whole run of 2048 frames at a small
// one, and the fastest, smallest box against a thin wall, which tunnels with
// one step per frame and no CCD and is held by the automatic substeps and CCD
// (the default) as by 8 fixed substeps.
#include <btBulletDynamicsCommon.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "physics/world.h"
#include "tests/hard_cases/hard_case_support.h"

namespace overlap::hard_cases {
namespace {

// Scenes 3 and 4 at kBoxes boxes for kFrames frames: the first fall, then a
// quarter turn of the gravity (200 / 120 rad), which throws the pile across
// the container.  Both scenes take 23 s together on the 2-core development
// machine (Release; 300 boxes are already covered by tests/physics).
constexpr int kBoxes = 1000;
constexpr int kFrames = 200;

class FiftyGScenes : public ::testing::TestWithParam<int> {};

TEST_P(FiftyGScenes, NoBoxEscapesAndTheStateStaysFinite) {
  physics::SceneConfig config = physics::SceneConfig::forScene(GetParam());
  config.objects = kBoxes;
  physics::PhysicsWorld world(config, physics::WorldOptions{"bvh"});
  int most_sunk = 0;
  for (int frame = 0; frame < kFrames; ++frame) {
    const physics::FrameReport report = world.stepFrame();
    ASSERT_EQ(report.escaped, 0) << "frame " << frame;
    ASSERT_EQ(report.removed_from_simulation, 0) << "frame " << frame;
    most_sunk = std::max(most_sunk, report.sunk);
    const std::vector<physics::BoxPose> poses = world.boxPoses();
    ASSERT_EQ(poses.size(), static_cast<std::size_t>(kBoxes));
    for (const physics::BoxPose& pose : poses) {
      ASSERT_TRUE(std::isfinite(pose.centre[0]) && std::isfinite(pose.centre[1]) &&
                  std::isfinite(pose.centre[2]))
          << "frame " << frame;
    }
    ASSERT_TRUE(everyBodyIsFinite(world)) << "frame " << frame;
  }
  // Sinking into a wall is an error to report, not a failure (docs/SCENES.md).
  std::printf("[ sunk     ] scene %d: at most %d of %d box centres outside the interior\n",
              GetParam(), most_sunk, kBoxes);
}

// A whole run, 2048 frames, at 100 boxes: gravity turns through every
// direction many times, with the automatic substeps and CCD.
TEST_P(FiftyGScenes, AWholeRunAtSmallNKeepsEveryBoxInside) {
  physics::SceneConfig config = physics::SceneConfig::forScene(GetParam());
  config.objects = 100;
  physics::PhysicsWorld world(config, physics::WorldOptions{"bvh"});
  for (int frame = 0; frame < 2048; ++frame) {
    const physics::FrameReport report = world.stepFrame();
    ASSERT_EQ(report.escaped, 0) << "frame " << frame;
    ASSERT_EQ(report.removed_from_simulation, 0) << "frame " << frame;
  }
  ASSERT_TRUE(everyBodyIsFinite(world));
}

INSTANTIATE_TEST_SUITE_P(Scenes3And4, FiftyGScenes, ::testing::Values(3, 4),
                         [](const ::testing::TestParamInfo<int>& param_info) {
                           return "scene" + std::to_string(param_info.param);
                         });

// The highest speed scenes 3 and 4 reach, about a box's free fall across the
// whole interior under 50 g, sqrt(2 * 50 g * L).  Measured with bvh at the paper's
// largest count, 3500 boxes over 800 frames: 252.3 m/s in scene 4 (L = 67.8 m,
// bound 257.8 m/s), a small box in the first fall; 161.4 m/s in scene 3
// (L = 32.7 m, bound 179.0 m/s).  Collisions can fling a small box faster than
// its own fall (249.8 m/s at 1000 boxes, where the bound is 210.2), so the
// measured top speed, not the bound, sets the case.
constexpr double kHighestSceneSpeed = 253.0;  // m/s
// A box tunnels once one step can carry its centre past the wall's middle
// (the contact then pushes it out on the far side): at 253 m/s a step of
// 1/240 s (8 substeps) travels 1.05 m, so a wall must be over 2.1 m thick.
// 2.0 m let 2 of 300 boxes through, 2.2 m none; 2.5 m keeps a margin.  The
// scenes' own walls are max(2 m, L / 8): 8.5 m where this speed is reached.
constexpr double kThinWall = 2.5;  // m
constexpr int kFastBoxes = 300;

struct ThinWallRun {
  int most_substeps;  // the largest K of any frame
  int most_escaped;   // boxes beyond a wall's outer face, the most in any frame
};

// 0.1 m boxes (the smallest any scene has) shot at kHighestSceneSpeed
// straight at the walls, each along an axis, either way; the scene places
// them, so each meets its wall at another phase of the step.  Scene 4's
// gravity stays on.
ThinWallRun shootAtThinWalls(int substeps, physics::CcdMode ccd) {
  physics::SceneConfig config = physics::SceneConfig::forScene(4);
  config.objects = kFastBoxes;
  config.small = config.average = config.large = physics::SizeRange{0.1, 0.1};
  config.initial_speed = 0;
  config.wall_min_thickness = kThinWall;
  config.wall_fraction = 0;
  config.fill_fraction = 1e-4;  // an interior of 14 m: every box meets its wall in frame 0 or 1
  physics::PhysicsWorld world(config, physics::WorldOptions{"bvh", substeps, ccd});
  // The scene draws velocities in random directions; these need aiming, so
  // they are set on the bodies directly (box i is rigid body i).
  const btCollisionObjectArray& bodies = world.bulletWorld().getCollisionObjectArray();
  for (int i = 0; i < kFastBoxes; ++i) {
    btVector3 velocity(0, 0, 0);
    velocity[i % 3] =
        static_cast<btScalar>((i / 3) % 2 == 0 ? kHighestSceneSpeed : -kHighestSceneSpeed);
    btRigidBody::upcast(bodies[i])->setLinearVelocity(velocity);
  }
  ThinWallRun run{0, 0};
  for (int frame = 0; frame < 30; ++frame) {
    const physics::FrameReport report = world.stepFrame();
    run.most_escaped = std::max(run.most_escaped, report.escaped);
    run.most_substeps = std::max(run.most_substeps, report.substeps);
  }
  return run;
}

TEST(ThinWall, FastestSmallestBoxTunnelsWithOneStepPerFrameAndNoCcd) {
  const ThinWallRun run = shootAtThinWalls(1, physics::CcdMode::kOff);
  ASSERT_EQ(run.most_substeps, 1);
  EXPECT_GT(run.most_escaped, 0) << "the negative control must tunnel";
}

TEST(ThinWall, EightFixedSubstepsHoldTheFastestSmallestBox) {
  EXPECT_EQ(shootAtThinWalls(8, physics::CcdMode::kOff).most_escaped, 0);
}

TEST(ThinWall, AutomaticSubstepsHoldTheFastestSmallestBoxWithOrWithoutCcd) {
  for (const physics::CcdMode ccd : {physics::CcdMode::kAuto, physics::CcdMode::kOff}) {
    const ThinWallRun run = shootAtThinWalls(physics::kAutoSubsteps, ccd);
    EXPECT_EQ(run.most_escaped, 0)
        << physics::ccdModeName(ccd) << ", K up to " << run.most_substeps;
  }
}

}  // namespace
}  // namespace overlap::hard_cases
