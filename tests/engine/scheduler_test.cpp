// The asynchronous frame: every task once per frame beside the whole step,
// the graph's order in the timeline, errors that leave nothing in flight, a
// thread cap that holds, and the same answers as running everything in
// sequence, under every broadphase.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <stdexcept>
#include <thread>

#include "gpu/base/stopwatch.h"
#include "tests/engine/scheduler_test_support.h"
#include "tests/needs_device.h"

namespace overlap::engine {
namespace {

using testing::smallScene;

struct Outcome {
  std::vector<physics::PairList> pairs;  // per frame
  std::uint64_t state_hash;
  std::uint64_t sound_checksum;
  std::uint64_t ai_checksum;
  std::uint64_t impacts;
};

Outcome runFrames(const std::string& algorithm, bool sync, int frames,
                  int substeps = physics::kAutoSubsteps,
                  physics::CcdMode ccd = physics::CcdMode::kAuto) {
  physics::PhysicsWorld world(smallScene(), physics::WorldOptions{algorithm, substeps, ccd});
  testing::DemoFrame demo(world, sync);
  FrameScheduler& scheduler = demo.scheduler;
  Outcome outcome;
  for (int frame = 0; frame < frames; ++frame) {
    scheduler.runFrame();
    outcome.pairs.push_back(world.cachedPairs());
  }
  outcome.state_hash = world.stateHash();
  outcome.sound_checksum = demo.tasks.soundChecksum();
  outcome.ai_checksum = demo.tasks.aiChecksum();
  outcome.impacts = demo.tasks.soundWork().impacts_started;
  return outcome;
}

// Spans of one frame by name, in the order drawn.
std::map<std::string, std::vector<Span>> spansOfFrame(const Timeline& timeline, int frame) {
  std::map<std::string, std::vector<Span>> spans;
  for (const Span& span : timeline.spans()) {
    if (span.frame == frame) spans[span.name].push_back(span);
  }
  return spans;
}

TEST(FrameScheduler, EveryTaskOncePerFrameAndEverySubstepsSearchAndNarrowphase) {
  for (const bool sync : {false, true}) {
    physics::PhysicsWorld world(smallScene(), physics::WorldOptions{"cpubf"});
    testing::DemoFrame demo(world, sync);
    FrameScheduler& scheduler = demo.scheduler;
    constexpr int kFrames = 25;
    std::vector<std::size_t> substeps_of_frame;  // K varies frame by frame (--substeps auto)
    for (int frame = 0; frame < kFrames; ++frame) {
      substeps_of_frame.push_back(static_cast<std::size_t>(scheduler.runFrame().physics.substeps));
    }
    EXPECT_EQ(demo.tasks.soundWork().frames, kFrames) << "sync " << sync;
    EXPECT_EQ(demo.tasks.aiWork().frames, kFrames) << "sync " << sync;
    for (int frame = 0; frame < kFrames; ++frame) {
      const std::size_t substeps = substeps_of_frame[static_cast<std::size_t>(frame)];
      ASSERT_GT(substeps, 1u);
      auto spans = spansOfFrame(demo.timeline, frame);
      for (const char* once : {"frame", "physics", "tasks", "sound", "ai"}) {
        EXPECT_EQ(spans[once].size(), 1u) << once << " in frame " << frame << ", sync " << sync;
      }
      for (const char* each : {"substep", "broadphase", "narrowphase"}) {
        ASSERT_EQ(spans[each].size(), substeps) << each << " in frame " << frame;
        for (std::size_t k = 0; k < substeps; ++k) {
          EXPECT_EQ(spans[each][k].substep, static_cast<int>(k)) << each << " in frame " << frame;
        }
      }
    }
  }
}

// The frame's graph, read back from the timeline: the tasks are launched
// before the first substep and joined after the last; every task runs
// inside that window; each substep's search starts after its substep does
// and ends before that substep's narrowphase.  In sync, every task is
// done before the physics starts.
TEST(FrameScheduler, TheTimelineShowsTheJobsInTheGraphsOrder) {
  for (const bool sync : {false, true}) {
    SCOPED_TRACE(sync ? "sync" : "async");
    physics::PhysicsWorld world(smallScene(), physics::WorldOptions{"cpubf"});
    testing::DemoFrame demo(world, sync);
    FrameScheduler& scheduler = demo.scheduler;
    for (int frame = 0; frame < 20; ++frame) {
      scheduler.runFrame();
      auto spans = spansOfFrame(demo.timeline, frame);
      const Span& tasks = spans["tasks"].front();
      const Span& physics = spans["physics"].front();
      const std::vector<Span>& substeps = spans["substep"];
      for (const char* task : {"sound", "ai"}) {
        const Span& span = spans[task].front();
        EXPECT_GE(span.at.start, tasks.at.start) << task << ", frame " << frame;
        EXPECT_LE(span.at.end, tasks.at.end) << task << ", frame " << frame;
        if (sync) {
          EXPECT_LE(span.at.end, physics.at.start) << task << ", frame " << frame;
        }
      }
      if (!sync) {
        EXPECT_LE(tasks.at.start, substeps.front().at.start) << "frame " << frame;
        EXPECT_GE(tasks.at.end, substeps.back().at.end) << "frame " << frame;
      }
      for (std::size_t k = 0; k < substeps.size(); ++k) {
        const Span& search = spans["broadphase"][k];
        const Span& narrowphase = spans["narrowphase"][k];
        EXPECT_GE(search.at.start, substeps[k].at.start) << "frame " << frame << ", substep " << k;
        EXPECT_LE(search.at.start, search.at.end) << "frame " << frame << ", substep " << k;
        if (search.lane == "search") {  // beside the narrowphase, ended inside it
          EXPECT_LE(search.at.start, narrowphase.at.start)
              << "frame " << frame << ", substep " << k;
          EXPECT_LE(search.at.end, narrowphase.at.end) << "frame " << frame << ", substep " << k;
        } else {
          EXPECT_LE(search.at.end, narrowphase.at.start) << "frame " << frame << ", substep " << k;
        }
        EXPECT_LE(narrowphase.at.end, substeps[k].at.end) << "frame " << frame << ", substep " << k;
      }
    }
  }
}

// frames.csv's timings are the physics' own clock readings; the scheduler
// times the step on its own.  Each part must fit in its whole: the phases in
// the physics' total, that total in the step the scheduler saw; and every
// substep draws one broadphase span.  A part counted twice, in the wrong unit
// or outside its phase breaks one of these.
TEST(FrameScheduler, TheStepsTimedPartsFitInsideTheStepTheSchedulerTimed) {
  physics::PhysicsWorld world(smallScene(), physics::WorldOptions{"cpubf"});
  testing::DemoFrame demo(world, false);
  double broadphase_ms = 0;
  for (int frame = 0; frame < 10; ++frame) {
    const ScheduledFrame scheduled = demo.scheduler.runFrame();
    const physics::FrameTimings& t = scheduled.physics.timings;
    constexpr double kRounding = 1e-6;  // ms: the sums' floating-point rounding
    EXPECT_LE(t.update_ms + t.broadphase_ms + t.narrowphase_ms + t.solver_ms + t.integrate_ms,
              t.total_ms + kRounding)
        << "frame " << frame;
    EXPECT_LE(t.total_ms, toMilliseconds(scheduled.step.length()) + kRounding) << "frame " << frame;
    EXPECT_EQ(spansOfFrame(demo.timeline, frame)["broadphase"].size(),
              static_cast<std::size_t>(scheduled.physics.substeps))
        << "frame " << frame;
    broadphase_ms += t.broadphase_ms;
  }
  EXPECT_GT(broadphase_ms, 0) << "every substep searches its pairs";
}

// A task that throws leaves nothing in flight.  The step
// finishes, every other task finishes, the error names
// the task, the frame and the cause, and the next frames run normally.
TEST(FrameScheduler, ATaskThatThrowsIsReportedAfterEverythingIsJoined) {
  for (const bool sync : {false, true}) {
    SCOPED_TRACE(sync ? "sync" : "async");
    physics::PhysicsWorld world(smallScene(), physics::WorldOptions{"cpubf"});
    testing::DemoFrame demo(world, sync);
    FrameScheduler& scheduler = demo.scheduler;
    int calls = 0;
    scheduler.addTask("physics-free game logic", [&calls] {
      if (++calls == 4) throw std::runtime_error("the script divided by zero");
    });
    for (int frame = 0; frame < 3; ++frame) scheduler.runFrame();
    try {
      scheduler.runFrame();
      FAIL() << "the task's error was lost";
    } catch (const std::runtime_error& error) {
      EXPECT_STREQ(error.what(),
                   "task 'physics-free game logic' failed in frame 3: the script divided by zero");
    }
    EXPECT_EQ(world.framesDone(), 4);
    EXPECT_EQ(demo.tasks.soundWork().frames, 4u) << "the other tasks ran to the end";
    EXPECT_EQ(demo.tasks.aiWork().frames, 4u);
    for (int frame = 0; frame < 3; ++frame) EXPECT_NO_THROW(scheduler.runFrame());
    EXPECT_EQ(world.framesDone(), 7);
  }
}

// A task system of N threads (what `overlap run --threads N` makes) bounds
// every thread of the run, cpubf's search included: the main thread and
// N - 1 workers.  Counted in /proc/self/task from inside a task, while the
// tasks and the search run; nothing here asks for a CUDA device, so no
// thread of the driver's is counted.  Systems grow, as a worker that exists
// stays.
std::size_t threadsNow() {
  return static_cast<std::size_t>(
      std::distance(std::filesystem::directory_iterator("/proc/self/task"),
                    std::filesystem::directory_iterator{}));
}

// The threads the runtime itself keeps once a first thread was made: none,
// or ThreadSanitizer's background thread, which its runtime starts at the
// process's first thread.  One thread made and joined here starts it.
std::size_t runtimeThreads() {
  std::thread([] {}).join();
  return threadsNow() - 1;
}

TEST(FrameScheduler, AThreadCapBoundsEveryThreadOfTheRun) {
  if (threadsNow() != 1) {
    GTEST_SKIP() << threadsNow() << " threads before the test: earlier tests of this process left "
                 << "oneTBB workers; ctest runs each test in a process of its own";
  }
  const std::size_t runtime = runtimeThreads();
  for (const std::size_t cap : {1u, 2u, 3u}) {
    const std::unique_ptr<TaskSystem> tasks = makeTaskSystem(static_cast<int>(cap));
    physics::SceneConfig config = smallScene();
    config.objects = 400;
    physics::WorldOptions options{"cpubf"};
    options.tasks = tasks.get();
    physics::PhysicsWorld world(config, options);
    testing::DemoFrame demo(world, false);
    FrameScheduler& scheduler = demo.scheduler;
    std::atomic<std::size_t> most{0};
    scheduler.addTask("count threads", [&most] {
      for (int i = 0; i < 200; ++i) {
        std::size_t now = threadsNow();
        std::size_t seen = most.load();
        while (now > seen && !most.compare_exchange_weak(seen, now)) {
        }
      }
    });
    for (int frame = 0; frame < 10; ++frame) {
      scheduler.runFrame();
      most = std::max(most.load(), threadsNow());
    }
    EXPECT_LE(most.load(), cap + runtime)
        << "threads with a cap of " << cap << " (" << runtime << " of the runtime's own)";
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

// Impact sounds start where contacts begin (a manifold's
// first point), not where a broadphase's AABBs first overlap, so every
// broadphase gives the same sound where it gives the same physics.
TEST(FrameScheduler, EveryBroadphaseSoundsTheSame) {
  // The sound can only be compared where the physics is the same.  Bullet's
  // physics may differ by broadphase: with CCD the states part (see
  // tests/hard_cases/determinism_test.cpp), and sap's quantized boxes can
  // pair two boxes a hair apart, which the narrowphase then gives a
  // speculative contact.  Fixed K = 8 without CCD keeps all four identical
  // on this scene (checked below).
  const Outcome bf = runFrames("bf", false, 60, 8, physics::CcdMode::kOff);
  ASSERT_GT(bf.impacts, 10u) << "the scene should sound contacts";
  for (const char* algorithm : {"sap", "bvh", "cpubf"}) {
    const Outcome other = runFrames(algorithm, false, 60, 8, physics::CcdMode::kOff);
    ASSERT_EQ(other.state_hash, bf.state_hash) << algorithm << ": not the same physics";
    EXPECT_EQ(other.sound_checksum, bf.sound_checksum) << algorithm;
  }
}

TEST(FrameScheduler, AsyncAndSyncGiveTheSameAnswersWithTheGpuFinders) {
  const Outcome reference = runFrames("cpubf", true, 30);
  for (const char* algorithm : {"gpubf", "gpubf-paper", "gpusap"}) {
    OVERLAP_NEEDS_DEVICE_FOR(algorithm);
    const Outcome async_run = runFrames(algorithm, false, 30);
    EXPECT_EQ(async_run.pairs, reference.pairs) << algorithm;
    EXPECT_EQ(async_run.state_hash, reference.state_hash) << algorithm;
    EXPECT_EQ(async_run.sound_checksum, reference.sound_checksum) << algorithm;
    EXPECT_EQ(async_run.ai_checksum, reference.ai_checksum) << algorithm;
  }
}

TEST(FrameScheduler, NewContactsBecomeImpactSounds) {
  physics::PhysicsWorld world(smallScene(), physics::WorldOptions{"bvh"});
  testing::DemoFrame demo(world, false);
  FrameScheduler& scheduler = demo.scheduler;
  std::size_t contacts = 0;
  for (int frame = 0; frame < 30; ++frame) {
    scheduler.runFrame();
    contacts += world.newContacts().size();
  }
  EXPECT_GT(contacts, 0u);
  EXPECT_GT(demo.tasks.soundWork().impacts_started, 0u);
}

// Without registered jobs the frame is the step alone: nothing to join.
TEST(FrameScheduler, PhysicsOnlyRunsNoTasks) {
  physics::PhysicsWorld world(smallScene(), physics::WorldOptions{"cpubf"});
  Timeline timeline;
  FrameScheduler scheduler(world, SchedulerOptions{}, timeline);
  const ScheduledFrame frame = scheduler.runFrame();
  EXPECT_FALSE(frame.tasks);
  EXPECT_FALSE(frame.wait);
  EXPECT_TRUE(frame.task_runs.empty());
  EXPECT_EQ(frame.taskTime(kSoundTask) + frame.taskTime(kAiTask) + frame.waitTime(),
            Clock::duration::zero());
  EXPECT_GT(frame.physics.pairs, 0);
}

// The step is added after every job registered before the first frame, so
// one registered later could not be ordered before it.
TEST(FrameScheduler, JobsAreRegisteredBeforeTheFirstFrame) {
  physics::PhysicsWorld world(smallScene(), physics::WorldOptions{"cpubf"});
  testing::DemoFrame demo(world, false);
  demo.scheduler.runFrame();
  EXPECT_THROW(demo.scheduler.addTask("late", [] {}), std::logic_error);
  EXPECT_THROW(demo.scheduler.addBeforeStep("late", [] {}), std::logic_error);
}

TEST(OverlapOf, IsTheTimeTwoIntervalsShare) {
  const auto at = [](int ms) { return Clock::time_point(std::chrono::milliseconds(ms)); };
  const Interval ten{at(0), at(10)};
  EXPECT_EQ(overlapOf(ten, ten), std::chrono::milliseconds(10));
  EXPECT_EQ(overlapOf(ten, {at(2), at(4)}), std::chrono::milliseconds(2));
  EXPECT_EQ(overlapOf({at(-5), at(2)}, ten), std::chrono::milliseconds(2));
  EXPECT_EQ(overlapOf(ten, {at(11), at(12)}), Clock::duration::zero());
  EXPECT_EQ(overlapOf(ten, {at(10), at(12)}), Clock::duration::zero());
}

}  // namespace
}  // namespace overlap::engine
