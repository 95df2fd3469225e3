// Bad values mid-run: a NaN, an infinite and a 1e30 position put into boxes
// in contact with others, in scene 2 (where Bullet itself flags the body) and
// scene 4 (whose bodies never sleep, so Bullet cannot flag them).  Each box must leave the
// simulation with a message naming it, be counted in FrameReport::removed_from_simulation, and take
// nothing with it: the run goes on, no other box turns non-finite, and the
// broadphase's pairs stay exact (the catalogue's exact ones) or miss nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <tuple>
#include <vector>

#include "physics/broadphase/broadphase_factory.h"
#include "physics/world.h"
#include "tests/engine/scheduler_test_support.h"
#include "tests/hard_cases/hard_case_support.h"

namespace overlap::hard_cases {
namespace {

constexpr int kBoxes = 120;
constexpr int kFramesToSettle = 20;  // enough for contacts, at 1 g and at 50 g
constexpr int kFramesAfterEach = 15;

struct BadValue {
  const char* what;
  Eigen::Vector3d position;
  const char* shown;  // how the removal message prints the bad coordinate
};

const BadValue kBadValues[] = {
    {"NaN", {std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0}, "(nan, 0, 0)"},
    {"infinity", Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()),
     "(inf, inf, inf)"},
    {"1e30", Eigen::Vector3d::Constant(1e30), "(1e+30, 1e+30, 1e+30)"},
};

class BadValuesMidRun : public ::testing::TestWithParam<std::tuple<int, const char*>> {};

TEST_P(BadValuesMidRun, TheBoxLeavesWithAMessageAndNothingElseBreaks) {
  const auto [scene, algorithm_name] = GetParam();
  const std::string algorithm = algorithm_name;
  physics::SceneConfig config = physics::SceneConfig::forScene(scene);
  config.objects = kBoxes;
  physics::PhysicsWorld world(config, physics::WorldOptions{algorithm});
  for (int frame = 0; frame < kFramesToSettle; ++frame) world.stepFrame();

  // Victims in contact with others: a NaN that reached the solver would spread to them.
  std::vector<int> victims;
  const std::vector<physics::BoxPose> poses = world.boxPoses();
  for (int i = 0; i < kBoxes && victims.size() < std::size(kBadValues); ++i) {
    if (poses[static_cast<std::size_t>(i)].in_contact) victims.push_back(i);
  }
  ASSERT_EQ(victims.size(), std::size(kBadValues)) << "too few boxes in contact";

  int removed = 0;
  for (std::size_t v = 0; v < std::size(kBadValues); ++v) {
    const BadValue& bad = kBadValues[v];
    const int victim = victims[v];
    SCOPED_TRACE(std::string(bad.what) + " into box " + std::to_string(victim) + ", " + algorithm);
    ::testing::internal::CaptureStderr();
    world.injectBoxPosition(victim, bad.position);  // out at once, as a step would leave it
    const physics::FrameReport report = world.stepFrame();
    const std::string messages = ::testing::internal::GetCapturedStderr();
    ++removed;
    EXPECT_NE(messages.find("box " + std::to_string(victim) + " left the simulation"),
              std::string::npos)
        << messages;
    EXPECT_NE(messages.find(bad.shown), std::string::npos) << messages;
    EXPECT_EQ(report.removed_from_simulation, removed);

    for (int frame = 0; frame < kFramesAfterEach; ++frame) {
      ::testing::internal::CaptureStderr();
      const physics::FrameReport later = world.stepFrame();
      EXPECT_EQ(::testing::internal::GetCapturedStderr(), "") << "frame " << later.frame;
      ASSERT_EQ(later.removed_from_simulation, removed) << "frame " << later.frame;
      ASSERT_TRUE(everyBodyIsFinite(world)) << "frame " << later.frame;
      const PairList cached = world.cachedPairs();
      const PairList exact = oraclePairs(world.aabbs(), kBoxes);  // walls never pair each other
      if (isExact(algorithm)) {
        ASSERT_TRUE(samePairs(cached, exact)) << "frame " << later.frame;
      } else {
        ASSERT_TRUE(missesNoPair(cached, exact)) << "frame " << later.frame;
      }
      for (const finders::IndexPair& pair : cached) {
        for (int i = 0; i <= static_cast<int>(v); ++i) {
          const auto gone = static_cast<std::uint32_t>(victims[static_cast<std::size_t>(i)]);
          ASSERT_TRUE(pair.a != gone && pair.b != gone) << "a removed box is still paired";
        }
      }
    }
    const std::vector<physics::BoxPose> remaining = world.boxPoses();
    EXPECT_EQ(remaining.size(), static_cast<std::size_t>(kBoxes - removed));
    for (const physics::BoxPose& pose : remaining) {
      ASSERT_TRUE(std::isfinite(pose.centre[0]) && std::isfinite(pose.centre[1]) &&
                  std::isfinite(pose.centre[2]));
    }
  }
  EXPECT_EQ(world.framesDone(),
            kFramesToSettle + static_cast<int>(std::size(kBadValues)) * (1 + kFramesAfterEach));
}

std::string sceneAndAlgorithm(
    const ::testing::TestParamInfo<std::tuple<int, const char*>>& param_info) {
  return "scene" + std::to_string(std::get<0>(param_info.param)) + "_" +
         std::get<1>(param_info.param);
}

INSTANTIATE_TEST_SUITE_P(ScenesAndBroadphases, BadValuesMidRun,
                         ::testing::Combine(::testing::Values(2, 4),
                                            ::testing::Values("bf", "sap", "bvh", "cpubf",
                                                              "cpusap")),
                         sceneAndAlgorithm);

// Boxes that leave inside a substep: at 1e6 m/s^2 times 100 over 1 s frames
// (every value within its documented bounds) boxes reach AABBs too large for
// Bullet, which flags them in the AABB update; they leave there, after CCD
// made its predictive contacts for them.  Every box that leaves must leave
// nothing behind that the narrowphase, the islands or the solver still
// reads; the run goes on with every broadphase, CCD mode and solver.
struct Leaving {
  const char* algorithm;
  physics::CcdMode ccd;
  physics::SolverMode solver;
};

class BoxesLeavingMidSubstep : public ::testing::TestWithParam<Leaving> {};

TEST_P(BoxesLeavingMidSubstep, LeaveAndTheRunGoesOn) {
  const Leaving& leaving = GetParam();
  physics::SceneConfig config = physics::SceneConfig::forScene(1);
  config.objects = 50;
  config.g = 1e6;
  config.gravity_scale = 100;
  config.frame_time = 1;
  physics::WorldOptions options{leaving.algorithm};
  options.ccd = leaving.ccd;
  options.solver = leaving.solver;
  physics::PhysicsWorld world(config, options);
  ::testing::internal::CaptureStderr();
  int removed = 0;
  for (int frame = 0; frame < 3; ++frame) {
    const std::string algorithm = leaving.algorithm;
    if (algorithm == "sap" || algorithm == "sap32") {
      // Bullet's sweep and prune cannot hold boxes flown 10^5 to 10^7 m off
      // without cells coarser than the boxes (16-bit sap's grid, sap32's
      // floats): it stops the run naming that, never pairs boxes that do
      // not touch (the others run on).
      try {
        removed = world.stepFrame().removed_from_simulation;
      } catch (const std::invalid_argument& error) {
        ::testing::internal::GetCapturedStderr();
        EXPECT_NE(
            std::string(error.what()).find(algorithm == "sap" ? "16-bit grid" : "32-bit grid"),
            std::string::npos)
            << error.what();
        return;
      }
      continue;
    }
    const physics::FrameReport report = world.stepFrame();
    ASSERT_GE(report.removed_from_simulation, removed) << "frame " << frame;
    removed = report.removed_from_simulation;
    ASSERT_TRUE(everyBodyIsFinite(world)) << "frame " << frame;
  }
  const std::string messages = ::testing::internal::GetCapturedStderr();
  EXPECT_GT(removed, 0) << "the scene should break boxes";
  EXPECT_NE(messages.find("inside an AABB too large for Bullet"), std::string::npos) << messages;
  EXPECT_EQ(world.boxPoses().size(), static_cast<std::size_t>(config.objects - removed));
  EXPECT_EQ(world.bulletWorld().getNumCollisionObjects(), config.objects - removed + 6);
}

std::string leavingName(const ::testing::TestParamInfo<Leaving>& param_info) {
  std::string name = param_info.param.algorithm;
  name += param_info.param.ccd == physics::CcdMode::kAll ? "_ccdAll" : "_ccdAuto";
  name += param_info.param.solver == physics::SolverMode::kBullet ? "_bulletSolver" : "_pileSolver";
  return name;
}

std::vector<Leaving> leavingCases() {
  std::vector<Leaving> cases;
  for (const char* algorithm : {"bf", "sap", "sap32", "bvh", "cpubf", "cpusap"}) {
    for (const physics::CcdMode ccd : {physics::CcdMode::kAuto, physics::CcdMode::kAll}) {
      for (const physics::SolverMode solver :
           {physics::SolverMode::kPile, physics::SolverMode::kBullet}) {
        cases.push_back({algorithm, ccd, solver});
      }
    }
  }
  return cases;
}

INSTANTIATE_TEST_SUITE_P(BroadphasesCcdAndSolvers, BoxesLeavingMidSubstep,
                         ::testing::ValuesIn(leavingCases()), leavingName);

// A box made NaN between two scheduled frames is out of
// every consumer from the next frame on: the AI and sound tasks (which would
// throw on a NaN obstacle), the poses a renderer draws, the speeds, the AABBs
// a recorder writes.  The run goes on and the other boxes' pairs stay exact.
TEST(BadValuesThroughTheScheduler, ANaNBoxLeavesEveryConsumerAndTheRunCompletes) {
  for (const bool sync : {false, true}) {
    SCOPED_TRACE(sync ? "sync" : "async");
    physics::SceneConfig config = physics::SceneConfig::forScene(4);
    config.objects = kBoxes;
    physics::PhysicsWorld world(config, physics::WorldOptions{"cpubf"});
    engine::testing::DemoFrame demo(world, sync);
    engine::FrameScheduler& scheduler = demo.scheduler;
    for (int frame = 0; frame < kFramesToSettle; ++frame) scheduler.runFrame();

    int victim = -1;
    const std::vector<physics::BoxPose> poses = world.boxPoses();
    for (int i = 0; i < kBoxes && victim < 0; ++i) {
      if (poses[static_cast<std::size_t>(i)].in_contact) victim = i;
    }
    ASSERT_GE(victim, 0) << "no box in contact";
    ::testing::internal::CaptureStderr();
    world.injectBoxPosition(victim, {std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0});
    const std::string messages = ::testing::internal::GetCapturedStderr();
    EXPECT_NE(messages.find("box " + std::to_string(victim) + " left the simulation at frame " +
                            std::to_string(kFramesToSettle)),
              std::string::npos)
        << messages;

    for (int frame = 0; frame < kFramesAfterEach; ++frame) {
      engine::ScheduledFrame scheduled;
      ASSERT_NO_THROW(scheduled = scheduler.runFrame()) << "frame " << kFramesToSettle + frame;
      EXPECT_EQ(scheduled.physics.removed_from_simulation, 1);
      ASSERT_TRUE(samePairs(world.cachedPairs(), oraclePairs(world.aabbs(), kBoxes)));
      EXPECT_EQ(world.boxPoses().size(), static_cast<std::size_t>(kBoxes - 1));
      EXPECT_EQ(world.boxSpeeds()[static_cast<std::size_t>(victim)], 0.0f);
      for (const physics::NewContact& contact : world.newContacts()) {
        EXPECT_TRUE(contact.a != victim && contact.b != victim);
      }
      const physics::Aabb gone = world.aabbs()[static_cast<std::size_t>(victim)];
      EXPECT_GT(gone.min[0], gone.max[0]) << "a removed box's AABB overlaps nothing";
    }
    EXPECT_EQ(demo.tasks.aiWork().frames,
              static_cast<std::uint64_t>(kFramesToSettle + kFramesAfterEach));
  }
}

}  // namespace
}  // namespace overlap::hard_cases
