// The Bullet adapter: determinism, exact pairs, containment.
#include "physics/world.h"

#include <btBulletDynamicsCommon.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <set>
#include <string>

#include "gpu/pair_finder.h"
#include "tests/needs_device.h"
#include "tests/physics/aabb_oracle.h"

namespace overlap::physics {
namespace {

SceneConfig smallScene(int scene, int objects, std::uint64_t seed = 42) {
  SceneConfig config = SceneConfig::forScene(scene);
  config.objects = objects;
  config.seed = seed;
  return config;
}

std::uint64_t hashAfter(const SceneConfig& config, const std::string& algorithm, int frames) {
  PhysicsWorld world(config, WorldOptions{algorithm});
  for (int frame = 0; frame < frames; ++frame) world.stepFrame();
  return world.stateHash();
}

using physics::testing::oraclePairs;

// At the edges of scene 4's size bounds (the smallest and largest edge, the
// greatest ratio between them), the physics stays finite and keeps its boxes.
TEST(PhysicsWorld, SizesAtTheirBoundsKeepEnergiesFiniteAndTheBoxesInside) {
  const std::vector<std::array<SizeRange, 3>> cases = {
      {{{kSmallestEdge, kSmallestEdge}, {0.1, 0.1}, {1, 1}}},  // the greatest ratio, small
      {{{10, 10}, {100, 100}, {kLargestEdge, kLargestEdge}}},  // the greatest ratio, large
      {{{kLargestEdge, kLargestEdge}, {kLargestEdge, kLargestEdge}, {kLargestEdge, kLargestEdge}}},
  };
  for (const auto& [small, average, large] : cases) {
    SceneConfig config = SceneConfig::forScene(4);
    config.objects = 150;
    config.small = small;
    config.average = average;
    config.large = large;
    PhysicsWorld world(config, WorldOptions{});
    for (int frame = 0; frame < 90; ++frame) {
      const FrameReport report = world.stepFrame();
      ASSERT_TRUE(std::isfinite(report.kinetic_energy) && std::isfinite(report.potential_energy))
          << small.lo << ".." << large.hi << ", frame " << frame;
      ASSERT_EQ(report.removed_from_simulation, 0) << small.lo << ".." << large.hi;
    }
  }
}

TEST(PhysicsWorld, BuildsBoxesAndSixWalls) {
  PhysicsWorld world(smallScene(4, 120), WorldOptions{"bvh"});
  EXPECT_EQ(world.bulletWorld().getNumCollisionObjects(), 126);
  EXPECT_EQ(world.aabbs().size(), 126u);
  EXPECT_TRUE(world.automaticSubsteps());
  const FrameReport report = world.stepFrame();
  EXPECT_EQ(report.frame, 0);
  EXPECT_EQ(report.substeps, world.substeps());
  EXPECT_GE(report.substeps, 1);
  EXPECT_EQ(report.escaped, 0);
  EXPECT_GE(report.timings.total_ms, report.timings.broadphase_ms + report.timings.solver_ms);
}

TEST(PhysicsWorld, SameSeedSameStateDifferentSeedDifferentState) {
  for (int scene : {2, 4}) {
    const std::uint64_t first = hashAfter(smallScene(scene, 80), "bvh", 100);
    EXPECT_EQ(first, hashAfter(smallScene(scene, 80), "bvh", 100)) << "scene " << scene;
    EXPECT_NE(first, hashAfter(smallScene(scene, 80, 7), "bvh", 100)) << "scene " << scene;
  }
}

TEST(PhysicsWorld, SimpleBroadphaseCacheEqualsBruteForceOracle) {
  PhysicsWorld world(smallScene(4, 300), WorldOptions{"bf"});
  std::size_t checked_pairs = 0;
  for (int frame = 0; frame < 60; ++frame) {
    world.stepFrame();
    if (frame % 10 != 9) continue;
    const auto expected = oraclePairs(world.aabbs(), 300);
    EXPECT_EQ(world.cachedPairs(), expected) << "frame " << frame;
    checked_pairs += expected.size();
  }
  EXPECT_GT(checked_pairs, 100u) << "the scene should be in contact by now";
}

class OurBroadphaseTest : public ::testing::TestWithParam<const char*> {};

TEST_P(OurBroadphaseTest, CacheStaysExactAndPersistentOverScene4) {
  // Our broadphase inside a running world: every frame the cache is the exact
  // pair set, each pair once, and a pair that stays keeps its cache entry (a
  // marker left on the entry survives; a removed and re-added pair would come
  // back without it).  One substep per frame, so a frame is one search.
  OVERLAP_NEEDS_DEVICE_FOR(GetParam());
  PhysicsWorld world(smallScene(4, 250), WorldOptions{GetParam(), 1});
  static int marker;
  std::set<finders::IndexPair> previous;
  std::size_t kept = 0;
  for (int frame = 0; frame < 80; ++frame) {
    world.stepFrame();
    ASSERT_EQ(world.cachedPairs(), oraclePairs(world.aabbs(), 250)) << "frame " << frame;
    std::set<finders::IndexPair> current;
    btBroadphasePairArray& array =
        world.broadphase().getOverlappingPairCache()->getOverlappingPairArray();
    for (int i = 0; i < array.size(); ++i) {
      const auto* a = static_cast<const btCollisionObject*>(array[i].m_pProxy0->m_clientObject);
      const auto* b = static_cast<const btCollisionObject*>(array[i].m_pProxy1->m_clientObject);
      const finders::IndexPair key = orderedPair(a->getUserIndex(), b->getUserIndex());
      ASSERT_TRUE(current.insert(key).second) << "duplicate pair in frame " << frame;
      if (previous.count(key) != 0) {
        EXPECT_EQ(array[i].m_internalInfo1, &marker) << "pair lost its entry in frame " << frame;
        ++kept;
      }
      array[i].m_internalInfo1 = &marker;
    }
    previous = std::move(current);
  }
  EXPECT_GT(kept, 1000u);
}

INSTANTIATE_TEST_SUITE_P(Finders, OurBroadphaseTest,
                         ::testing::Values("cpubf", "cpusap", "gpubf", "gpubf-paper", "gpusap"),
                         [](const ::testing::TestParamInfo<const char*>& param_info) {
                           return param_info.param == std::string("gpubf-paper")
                                      ? std::string("gpubf_paper")
                                      : std::string(param_info.param);
                         });

TEST(PhysicsWorld, BulletsConservativeBroadphasesMissNoPair) {
  // SAP quantizes and DBVT fattens, so their caches may hold extra pairs, but
  // every exact pair of the AABBs they were given must be there.
  for (const char* algorithm : {"sap", "sap32", "bvh"}) {
    PhysicsWorld world(smallScene(4, 200), WorldOptions{algorithm});
    for (int frame = 0; frame < 40; ++frame) {
      world.stepFrame();
      const auto cached = world.cachedPairs();
      const auto exact = oraclePairs(world.aabbs(), 200);
      ASSERT_FALSE(exact.empty());
      EXPECT_TRUE(std::includes(cached.begin(), cached.end(), exact.begin(), exact.end()))
          << algorithm << " frame " << frame;
    }
  }
}

TEST(PhysicsWorld, NoBoxPassesThroughAWallAt50g) {
  for (int scene : {3, 4}) {
    PhysicsWorld world(smallScene(scene, 300), WorldOptions{"bvh"});
    int most_escaped = 0;
    for (int frame = 0; frame < 300; ++frame) {
      const FrameReport report = world.stepFrame();
      most_escaped = std::max(most_escaped, report.escaped);
      ASSERT_EQ(report.removed_from_simulation, 0) << "scene " << scene << " frame " << frame;
    }
    EXPECT_EQ(most_escaped, 0) << "scene " << scene;
  }
}

TEST(PhysicsWorld, OneStepPerFrameAt50gLetsBoxesEscape) {
  // The negative control for the test above: without substeps or CCD they tunnel.
  // The count is recorded (--gtest_output=json: most_escaped).
  PhysicsWorld world(smallScene(3, 300), WorldOptions{"bvh", 1, CcdMode::kOff});
  int most_escaped = 0;
  for (int frame = 0; frame < 300; ++frame) {
    most_escaped = std::max(most_escaped, world.stepFrame().escaped);
  }
  RecordProperty("most_escaped", most_escaped);
  std::printf("scene 3, 300 boxes, 1 step per frame: %d escaped within 300 frames\n", most_escaped);
  EXPECT_GT(most_escaped, 0);
}

TEST(PhysicsWorld, FixedSubstepsAreKeptEveryFrame) {
  PhysicsWorld world(smallScene(3, 100), WorldOptions{"bvh", 3});
  for (int frame = 0; frame < 20; ++frame) EXPECT_EQ(world.stepFrame().substeps, 3);
  EXPECT_FALSE(world.automaticSubsteps());
}

TEST(PhysicsWorld, CcdModesFlagNoneSomeOrEveryBox) {
  // Scene 4's first fall at 50 g: by frame 5 the small boxes are fast for their size.
  int flagged[3] = {};
  const CcdMode modes[3] = {CcdMode::kOff, CcdMode::kAuto, CcdMode::kAll};
  for (int m = 0; m < 3; ++m) {
    PhysicsWorld world(smallScene(4, 150), WorldOptions{"bvh", kAutoSubsteps, modes[m]});
    for (int frame = 0; frame < 6; ++frame) flagged[m] = world.stepFrame().ccd_bodies;
  }
  EXPECT_EQ(flagged[0], 0);
  EXPECT_GT(flagged[1], 0);
  EXPECT_LT(flagged[1], 150);
  EXPECT_EQ(flagged[2], 150);
}

// Scene 1 at 150 boxes, 4 substeps: the pile is one island, quiet by frame
// 130, and asleep after Bullet's 2 s at rest; none sleeps without sleep.
constexpr int kQuietPileSubsteps = 4;

int sleepingAfterTheFall(SleepMode sleep) {
  PhysicsWorld world(smallScene(1, 150),
                     WorldOptions{"bvh", kQuietPileSubsteps, CcdMode::kAuto, sleep});
  int sleeping = 0;
  for (int frame = 0; frame < 240; ++frame) sleeping = world.stepFrame().sleeping;
  return sleeping;
}

TEST(PhysicsWorld, BoxesAtRestSleepInScene1UnlessSleepIsOff) {
  EXPECT_GT(sleepingAfterTheFall(SleepMode::kScene), 140);
  EXPECT_EQ(sleepingAfterTheFall(SleepMode::kOff), 0);
  EXPECT_THROW(
      PhysicsWorld(smallScene(3, 100), WorldOptions{"bvh", 0, CcdMode::kAuto, SleepMode::kOn}),
      std::invalid_argument);
}

TEST(PhysicsWorld, ASleepingPileWakesWhenABoxLandsOnIt) {
  PhysicsWorld world(smallScene(1, 150), WorldOptions{"bvh", kQuietPileSubsteps});
  FrameReport report;
  for (int frame = 0; frame < 240; ++frame) report = world.stepFrame();
  ASSERT_EQ(report.sleeping, 150);
  // Box 0 dropped from just above box 1: it wakes whatever it lands on.
  const BoxPose target = world.boxPoses()[1];
  world.injectBoxPosition(
      0, Eigen::Vector3d(target.centre[0], target.centre[1] + 2.0, target.centre[2]));
  int fewest_sleeping = 150;
  for (int frame = 0; frame < 15; ++frame) {
    fewest_sleeping = std::min(fewest_sleeping, world.stepFrame().sleeping);
  }
  EXPECT_LT(fewest_sleeping, 149) << "box 0 and at least the box it hit are awake";
}

TEST(PhysicsWorld, UnknownBroadphaseAndTooManyForSapAreRejected) {
  EXPECT_THROW(PhysicsWorld(smallScene(1, 100), WorldOptions{"octree"}), std::invalid_argument);
  EXPECT_THROW(PhysicsWorld(smallScene(1, 32761), WorldOptions{"sap"}), std::invalid_argument);
}

}  // namespace
}  // namespace overlap::physics
