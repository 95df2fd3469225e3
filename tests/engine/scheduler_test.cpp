// The asynchronous frame: every task once per frame, a join that waits for
// all of them, and the same answers as running everything in sequence.
#include <gtest/gtest.h>

#include <map>

#include "engine/frame_scheduler.h"
#include "gpu/pair_finder.h"

namespace overlap::engine {
namespace {

physics::SceneConfig smallScene() {
  physics::SceneConfig config = physics::SceneConfig::forScene(4);
  config.objects = 120;
  return config;
}

SchedulerOptions cheapTasks(bool sync) {
  SchedulerOptions options;
  options.sync = sync;
  options.sound.voices = 8;
  options.sound.background_voices = 4;
  options.ai.agents = 32;
  return options;
}

struct Outcome {
  std::vector<std::vector<std::pair<int, int>>> pairs;  // per frame
  std::uint64_t state_hash;
  std::uint64_t sound_checksum;
  std::uint64_t ai_checksum;
};

Outcome runFrames(const std::string& algorithm, bool sync, int frames) {
  physics::PhysicsWorld world(smallScene(), physics::WorldOptions{algorithm});
  Timeline timeline;
  FrameScheduler scheduler(world, cheapTasks(sync), timeline);
  Outcome outcome;
  for (int frame = 0; frame < frames; ++frame) {
    scheduler.runFrame();
    outcome.pairs.push_back(world.cachedPairs());
  }
  outcome.state_hash = world.stateHash();
  outcome.sound_checksum = scheduler.soundChecksum();
  outcome.ai_checksum = scheduler.aiChecksum();
  return outcome;
}

TEST(FrameScheduler, EveryTaskRunsExactlyOncePerFrame) {
  for (const bool sync : {false, true}) {
    physics::PhysicsWorld world(smallScene(), physics::WorldOptions{"cpubf"});
    Timeline timeline;
    FrameScheduler scheduler(world, cheapTasks(sync), timeline);
    constexpr int kFrames = 25;
    for (int frame = 0; frame < kFrames; ++frame) scheduler.runFrame();
    EXPECT_EQ(scheduler.soundWork()->frames, kFrames) << "sync " << sync;
    EXPECT_EQ(scheduler.aiWork()->frames, kFrames) << "sync " << sync;
    std::map<std::pair<int, std::string>, int> spans;
    for (const Span& span : timeline.spans()) ++spans[{span.frame, span.name}];
    for (int frame = 0; frame < kFrames; ++frame) {
      for (const char* task : {"sound", "ai", "search", "join"}) {
        EXPECT_EQ((spans[{frame, task}]), 1) << task << " in frame " << frame << ", sync " << sync;
      }
    }
  }
}

TEST(FrameScheduler, JoinWaitsForEveryTask) {
  physics::PhysicsWorld world(smallScene(), physics::WorldOptions{"cpubf"});
  ASSERT_TRUE(world.broadphaseRunsInBackground());
  Timeline timeline;
  FrameScheduler scheduler(world, cheapTasks(false), timeline);
  for (int frame = 0; frame < 25; ++frame) scheduler.runFrame();
  std::map<int, double> join_start;
  for (const Span& span : timeline.spans()) {
    if (span.name == "join") join_start[span.frame] = span.start_us;
  }
  for (const Span& span : timeline.spans()) {
    if (span.name != "sound" && span.name != "ai") continue;
    EXPECT_LE(span.start_us + span.duration_us, join_start.at(span.frame))
        << span.name << " of frame " << span.frame << " ended after the join began";
  }
}

TEST(FrameScheduler, AsyncAndSyncGiveTheSamePairsStateAndTasks) {
  for (const char* algorithm : {"cpubf", "bvh"}) {
    const Outcome async_run = runFrames(algorithm, false, 40);
    const Outcome sync_run = runFrames(algorithm, true, 40);
    EXPECT_EQ(async_run.pairs, sync_run.pairs) << algorithm;
    EXPECT_EQ(async_run.state_hash, sync_run.state_hash) << algorithm;
    EXPECT_EQ(async_run.sound_checksum, sync_run.sound_checksum) << algorithm;
    EXPECT_EQ(async_run.ai_checksum, sync_run.ai_checksum) << algorithm;
  }
}

TEST(FrameScheduler, AsyncAndSyncGiveTheSameAnswersWithTheGpuFinders) {
  std::string why;
  if (!gpu::cudaDeviceAvailable(&why)) GTEST_SKIP() << "no CUDA device: " << why;
  const Outcome reference = runFrames("cpubf", true, 30);
  for (const char* algorithm : {"gpubf", "gpubf-paper"}) {
    const Outcome async_run = runFrames(algorithm, false, 30);
    EXPECT_EQ(async_run.pairs, reference.pairs) << algorithm;
    EXPECT_EQ(async_run.state_hash, reference.state_hash) << algorithm;
    EXPECT_EQ(async_run.sound_checksum, reference.sound_checksum) << algorithm;
    EXPECT_EQ(async_run.ai_checksum, reference.ai_checksum) << algorithm;
  }
}

TEST(FrameScheduler, NewContactsBecomeImpactSounds) {
  physics::PhysicsWorld world(smallScene(), physics::WorldOptions{"bvh"});
  Timeline timeline;
  FrameScheduler scheduler(world, cheapTasks(false), timeline);
  std::size_t contacts = 0;
  for (int frame = 0; frame < 30; ++frame) {
    scheduler.runFrame();
    contacts += world.newContacts().size();
  }
  EXPECT_GT(contacts, 0u);
  EXPECT_GT(scheduler.soundWork()->impacts_started, 0u);
}

TEST(FrameScheduler, PhysicsOnlyRunsNoTasks) {
  physics::PhysicsWorld world(smallScene(), physics::WorldOptions{"cpubf"});
  Timeline timeline;
  SchedulerOptions options;
  options.tasks = false;
  FrameScheduler scheduler(world, options, timeline);
  const ScheduledFrame frame = scheduler.runFrame();
  EXPECT_EQ(scheduler.soundWork(), nullptr);
  EXPECT_EQ(frame.physics.timings.frame_work_ms, 0.0);
  EXPECT_GT(frame.physics.pairs, 0);
}

TEST(CoveredShare, CountsOverlappingIntervalsOnce) {
  EXPECT_DOUBLE_EQ(coveredShare(0, 10, {{0, 10}}), 1.0);
  EXPECT_DOUBLE_EQ(coveredShare(0, 10, {{2, 4}, {3, 6}}), 0.4);
  EXPECT_DOUBLE_EQ(coveredShare(0, 10, {{-5, 2}, {8, 20}}), 0.4);
  EXPECT_DOUBLE_EQ(coveredShare(0, 10, {{11, 12}}), 0.0);
  EXPECT_DOUBLE_EQ(coveredShare(0, 0, {{0, 1}}), 0.0);
}

}  // namespace
}  // namespace overlap::engine
