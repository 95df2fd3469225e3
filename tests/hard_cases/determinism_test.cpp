// Determinism: the same scene gives the same state, bit for bit, after a
// full run of 2048 frames (docs/SCENES.md), run after run, whatever the thread
// count cpubf or cpusap searches with, and whether the broadphase overlaps the frame's
// sound and AI tasks or runs after them.  The runs use the automatic
// substeps and CCD, so the frame-by-frame choices (K, CCD bodies) are
// compared too, but the finders' runs against Bullet's brute force, which
// go without CCD at a fixed K (below).
//
// Cost: one full run of scene 4 at 60 boxes takes 5 to 10 s on the 2-core
// development machine.  Each test below makes two to four of them and is its
// own ctest, so `ctest -j` spreads them over the cores.
#include <btBulletCollisionCommon.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "gpu/base/checksum.h"
#include "gpu/pair_finder.h"
#include "physics/broadphase/pair_finder_broadphase.h"
#include "physics/world.h"
#include "tests/engine/scheduler_test_support.h"
#include "tests/gpu/pair_test_support.h"
#include "tests/hard_cases/hard_case_support.h"

namespace overlap::hard_cases {
namespace {

constexpr int kRunBoxes = 60;
constexpr int kRunFrames = 2048;

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

std::uint64_t hashAfterRun(const std::string& algorithm, Choices* choices) {
  physics::PhysicsWorld world(scene4(kRunBoxes), physics::WorldOptions{algorithm});
  for (int frame = 0; frame < kRunFrames; ++frame) noteChoices(choices, world.stepFrame());
  return world.stateHash();
}

// Without CCD, at a fixed K of 6: the automatic policy would pay for CCD's
// absence with about 13 substeps a frame (twice the time for the same check);
// at 6 no box escapes scene 4 in 2048 frames.
std::uint64_t hashAfterRunWithoutCcd(const std::string& algorithm, TaskSystem* tasks = nullptr) {
  physics::WorldOptions options{algorithm, 6, physics::CcdMode::kOff};
  options.tasks = tasks;
  physics::PhysicsWorld world(scene4(kRunBoxes), options);
  for (int frame = 0; frame < kRunFrames; ++frame) world.stepFrame();
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

// The world's task system sets cpubf's threads, as `overlap run --threads`
// does (plain threads: as many as asked, whatever the core count).  Both bf and
// cpubf are exact and Bullet processes the pairs sorted by proxy id, so
// cpubf must also end where Bullet's own brute force ends.  Without CCD: with
// it the two part after a few frames of scene 4 although every broadphase's
// sweeps go through the same query tree (physics/broadphase/ccd_query_broadphase.h);
// what else CCD's contacts make order-dependent is not pinned down.
TEST(Determinism, CpubfEndsInTheSameStateWithOneTwoOrFourThreadsAndAsBulletsBruteForce) {
  const std::uint64_t bullet_bf = hashAfterRunWithoutCcd("bf");
  for (const int threads : {1, 2, 4}) {
    const auto tasks = makeTaskSystem(threads, TaskBackEnd::kPlainThreads);
    EXPECT_EQ(hashAfterRunWithoutCcd("cpubf", tasks.get()), bullet_bf) << threads << " thread(s)";
  }
}

// cpusap too is exact, whatever its thread count: it must end where bf ends
// (without CCD, as above).
TEST(Determinism, CpusapEndsInTheSameStateWithOneOrTwoThreadsAsBulletsBruteForce) {
  const std::uint64_t bullet_bf = hashAfterRunWithoutCcd("bf");
  for (const int threads : {1, 2}) {
    const auto tasks = makeTaskSystem(threads);
    EXPECT_EQ(hashAfterRunWithoutCcd("cpusap", tasks.get()), bullet_bf) << threads << " thread(s)";
  }
}

// The engine's frame: the sound and AI tasks beside the whole physics step,
// cpubf searching inside every substep (async), or the same jobs
// one after another (sync).  Every frame's pairs, the final state, the sound
// and the AI must be bit-identical over the full 2048 frames.
struct ScheduledRun {
  std::uint64_t pairs_digest = kFnv1aOffsetBasis;  // FNV-1a over every frame's pairs
  std::uint64_t state_hash = 0;
  std::uint64_t sound_checksum = 0;
  std::uint64_t ai_checksum = 0;
  std::uint64_t impacts = 0;
  Choices choices;  // K and CCD bodies, frame by frame
};

ScheduledRun scheduledRun(bool sync) {
  physics::PhysicsWorld world(scene4(kRunBoxes), physics::WorldOptions{"cpubf"});
  engine::testing::DemoFrame demo(world, sync);
  engine::FrameScheduler& scheduler = demo.scheduler;
  ScheduledRun run;
  for (int frame = 0; frame < kRunFrames; ++frame) {
    noteChoices(&run.choices, scheduler.runFrame().physics);
    const physics::PairList pairs = world.cachedPairs();
    run.pairs_digest = fnv1a(std::span<const finders::IndexPair>(pairs), run.pairs_digest);
    const std::array<int, 1> frame_separator{-1};
    run.pairs_digest = fnv1a(std::span<const int>(frame_separator), run.pairs_digest);
  }
  run.state_hash = world.stateHash();
  run.sound_checksum = demo.tasks.soundChecksum();
  run.ai_checksum = demo.tasks.aiChecksum();
  run.impacts = demo.tasks.soundWork().impacts_started;
  return run;
}

TEST(Determinism, AsyncAndSyncFramesGiveTheSamePairsStateAndSoundFor2048Frames) {
  const ScheduledRun async_run = scheduledRun(false);
  const ScheduledRun sync_run = scheduledRun(true);
  EXPECT_EQ(async_run.pairs_digest, sync_run.pairs_digest);
  EXPECT_EQ(async_run.state_hash, sync_run.state_hash);
  EXPECT_EQ(async_run.sound_checksum, sync_run.sound_checksum);
  EXPECT_EQ(async_run.ai_checksum, sync_run.ai_checksum);
  EXPECT_GT(async_run.impacts, 0u) << "the sound should have heard contacts";
  EXPECT_EQ(async_run.choices, sync_run.choices);
  expectVaryingChoices(async_run.choices);
}

// The pair-finder level, where the thread count is the finder's own: a
// PairFinderBroadphase over cpubf (or cpusap) with 1, 2 and 4 threads (the
// process allows 4 even on 2 cores) replays a recorded scene-4 pile; the
// caches must agree frame by frame.
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

std::vector<PairList> replayWithThreads(const RecordedFrames& frames, int threads,
                                        std::string_view finder) {
  btDefaultCollisionConfiguration collision_config;
  btCollisionDispatcher dispatcher(&collision_config);
  const auto tasks = makeTaskSystem(threads, TaskBackEnd::kPlainThreads);
  physics::PairFinderBroadphase broadphase(finders::makePairFinder(finder, *tasks));
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
      pairs.push_back(
          physics::orderedPair(array[p].m_pProxy0->m_uniqueId, array[p].m_pProxy1->m_uniqueId));
    }
    std::sort(pairs.begin(), pairs.end());
    pairs_per_frame.push_back(std::move(pairs));
  }
  for (btBroadphaseProxy* proxy : proxies) broadphase.destroyProxy(proxy, &dispatcher);
  return pairs_per_frame;
}

class FinderThreads : public ::testing::TestWithParam<std::string_view> {};

TEST_P(FinderThreads, SamePairsWithOneTwoOrFourThreads) {
  const RecordedFrames frames = recordScene4(300, 60);
  const std::vector<PairList> one = replayWithThreads(frames, 1, GetParam());
  std::size_t total = 0;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    EXPECT_TRUE(samePairs(one[f], oraclePairs(frames[f]))) << "frame " << f;
    total += one[f].size();
  }
  EXPECT_GT(total, 1000u) << "the pile should be in contact";
  for (const int threads : {2, 4}) {
    const std::vector<PairList> many = replayWithThreads(frames, threads, GetParam());
    for (std::size_t f = 0; f < frames.size(); ++f) {
      ASSERT_TRUE(samePairs(many[f], one[f])) << threads << " threads, frame " << f;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(CpuFinders, FinderThreads,
                         ::testing::ValuesIn(finders::testing::finderNames(false)),
                         finders::testing::finderTestName);

}  // namespace
}  // namespace overlap::hard_cases
