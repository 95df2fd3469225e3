// Determinism: the same scene gives the same state, bit for bit, after a
// full run of 2048 frames (SCENES.md), run after run, whatever the thread
// count cpubf searches with, and whether the broadphase overlaps the frame's
// sound and AI tasks or runs after them.  The runs use the automatic
// substeps and CCD, so the frame-by-frame choices (K, CCD bodies) are
// compared too.
//
// Cost: one full run of scene 4 at 60 boxes takes 5 to 10 s on the 2-core
// development machine.  Each test below makes two to four of them and is its
// own ctest, so `ctest -j` spreads them over the cores.
#include <btBulletCollisionCommon.h>
#include <gtest/gtest.h>
#include <oneapi/tbb/global_control.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "engine/frame_scheduler.h"
#include "gpu/pair_finder.h"
#include "physics/pair_finder_broadphase.h"
#include "physics/world.h"
#include "tests/hard_cases/hard_case_support.h"

namespace overlap::hard_cases {
namespace {

constexpr int kBoxes = 60;
constexpr int kFrames = 2048;

physics::SceneConfig scene4(int objects) {
  physics::SceneConfig config = physics::SceneConfig::forScene(4);
  config.objects = objects;
  return config;
}

// What the step policy chose each frame: (K, boxes with CCD).
using Choices = std::vector<std::pair<int, int>>;

void noteChoices(Choices* choices, const physics::FrameReport& report) {
  if (choices != nullptr) choices->emplace_back(report.substeps, report.ccd_bodies);
}

std::uint64_t hashAfterRun(const std::string& algorithm, Choices* choices = nullptr,
                           physics::CcdMode ccd = physics::CcdMode::kAuto) {
  physics::PhysicsWorld world(scene4(kBoxes),
                              physics::WorldOptions{algorithm, physics::kAutoSubsteps, ccd});
  for (int frame = 0; frame < kFrames; ++frame) noteChoices(choices, world.stepFrame());
  return world.stateHash();
}

// The choices must vary, or comparing them proves nothing.
void expectVaryingChoices(const Choices& choices) {
  const auto [fewest, most] = std::minmax_element(choices.begin(), choices.end());
  EXPECT_LT(fewest->first, most->first) << "K never changed";
  std::vector<int> ccd;
  for (const auto& choice : choices) ccd.push_back(choice.second);
  EXPECT_LT(*std::min_element(ccd.begin(), ccd.end()), *std::max_element(ccd.begin(), ccd.end()))
      << "the CCD bodies never changed";
}

TEST(Determinism, ThreeRunsOfScene4MakeTheSameChoicesAndEndInTheSameState) {
  Choices first_choices;
  const std::uint64_t first = hashAfterRun("bvh", &first_choices);
  expectVaryingChoices(first_choices);
  for (int run = 0; run < 2; ++run) {
    Choices choices;
    EXPECT_EQ(hashAfterRun("bvh", &choices), first);
    EXPECT_EQ(choices, first_choices);
  }
}

// PhysicsWorld names a broadphase and nothing more, so cpubf's threads are
// capped as `overlap run --threads` caps them, for the whole process (a cap
// above the core count leaves cpubf at one thread per core).  Both bf and
// cpubf are exact and Bullet processes the pairs sorted by proxy id, so
// cpubf must also end where Bullet's own brute force ends.  Without CCD:
// CCD's sweeps query the broadphase's rayTest, which btSimpleBroadphase
// answers with every proxy and ours with those the sweep's AABB meets, in
// another order, so a tie between two hits can go either way.
TEST(Determinism, CpubfEndsInTheSameStateWithOneTwoOrFourThreadsAndAsBulletsBruteForce) {
  const std::uint64_t bullet_bf = hashAfterRun("bf", nullptr, physics::CcdMode::kOff);
  for (const int threads : {1, 2, 4}) {
    const tbb::global_control cap(tbb::global_control::max_allowed_parallelism,
                                  static_cast<std::size_t>(threads));
    EXPECT_EQ(hashAfterRun("cpubf", nullptr, physics::CcdMode::kOff), bullet_bf)
        << threads << " thread(s)";
  }
}

// The engine's frame: cpubf searches on its worker while the sound and AI
// tasks run (async), or the tasks run first and the search after (sync).
std::uint64_t hashAfterScheduledRun(bool sync, Choices& choices) {
  physics::PhysicsWorld world(scene4(kBoxes), physics::WorldOptions{"cpubf"});
  engine::SchedulerOptions options;
  options.sync = sync;
  options.sound.voices = 4;
  options.sound.background_voices = 2;
  options.ai.agents = 16;
  engine::Timeline timeline;
  engine::FrameScheduler scheduler(world, options, timeline);
  for (int frame = 0; frame < kFrames; ++frame) noteChoices(&choices, scheduler.runFrame().physics);
  return world.stateHash();
}

TEST(Determinism, AsyncAndSyncFramesMakeTheSameChoicesAndEndInTheSameState) {
  Choices async_choices, sync_choices;
  EXPECT_EQ(hashAfterScheduledRun(false, async_choices), hashAfterScheduledRun(true, sync_choices));
  EXPECT_EQ(async_choices, sync_choices);
  expectVaryingChoices(async_choices);
}

// The pair-finder level, where the thread count is the finder's own: a
// PairFinderBroadphase over cpubf with 1, 2 and 4 threads (the process allows
// 4 even on 2 cores) replays a recorded scene-4 pile; the caches must agree
// frame by frame.
using RecordedFrames = std::vector<std::vector<physics::Aabb>>;

RecordedFrames recordScene4(int objects, int frames) {
  physics::PhysicsWorld world(scene4(objects), physics::WorldOptions{"bvh"});
  RecordedFrames recorded;
  for (int frame = 0; frame < frames; ++frame) {
    world.stepFrame();
    const std::vector<physics::Aabb> all = world.aabbs();  // boxes, then walls
    recorded.emplace_back(all.begin(), all.begin() + objects);
  }
  return recorded;
}

std::vector<PairList> replayWithThreads(const RecordedFrames& frames, int threads) {
  btDefaultCollisionConfiguration collision_config;
  btCollisionDispatcher dispatcher(&collision_config);
  physics::PairFinderBroadphase broadphase(
      gpu::makePairFinder(gpu::PairFinderKind::kCpuBruteForce, threads));
  auto corner = [](const float(&xyz)[3]) { return btVector3(xyz[0], xyz[1], xyz[2]); };
  std::vector<btBroadphaseProxy*> proxies;
  for (const physics::Aabb& b : frames.front()) {
    proxies.push_back(broadphase.createProxy(corner(b.min), corner(b.max), BOX_SHAPE_PROXYTYPE,
                                             nullptr, btBroadphaseProxy::DefaultFilter,
                                             btBroadphaseProxy::AllFilter, &dispatcher));
  }
  std::vector<PairList> pairs_per_frame;
  for (const std::vector<physics::Aabb>& frame : frames) {
    for (std::size_t i = 0; i < frame.size(); ++i) {
      broadphase.setAabb(proxies[i], corner(frame[i].min), corner(frame[i].max), &dispatcher);
    }
    broadphase.calculateOverlappingPairs(&dispatcher);
    const btBroadphasePairArray& array =
        broadphase.getOverlappingPairCache()->getOverlappingPairArray();
    PairList pairs;
    for (int p = 0; p < array.size(); ++p) {
      pairs.emplace_back(
          std::minmax(array[p].m_pProxy0->m_uniqueId, array[p].m_pProxy1->m_uniqueId));
    }
    std::sort(pairs.begin(), pairs.end());
    pairs_per_frame.push_back(std::move(pairs));
  }
  for (btBroadphaseProxy* proxy : proxies) broadphase.destroyProxy(proxy, &dispatcher);
  return pairs_per_frame;
}

TEST(Determinism, CpubfFindsTheSamePairsWithOneTwoOrFourThreads) {
  const tbb::global_control allow_four(tbb::global_control::max_allowed_parallelism, 4);
  const RecordedFrames frames = recordScene4(300, 60);
  const std::vector<PairList> one = replayWithThreads(frames, 1);
  std::size_t total = 0;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    EXPECT_TRUE(samePairs(one[f], oraclePairs(frames[f]))) << "frame " << f;
    total += one[f].size();
  }
  EXPECT_GT(total, 1000u) << "the pile should be in contact";
  for (const int threads : {2, 4}) {
    const std::vector<PairList> many = replayWithThreads(frames, threads);
    for (std::size_t f = 0; f < frames.size(); ++f) {
      ASSERT_TRUE(samePairs(many[f], one[f])) << threads << " threads, frame " << f;
    }
  }
}

}  // namespace
}  // namespace overlap::hard_cases
