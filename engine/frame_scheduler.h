// The asynchronous frame: the game loop this project is named for.
//
// Frame N is a small graph of jobs, run by FrameScheduler::runFrame() in this
// order; each names what it depends on.  Bullet is only ever called from the
// main thread.
//   1. snapshot  main      frame N-1's boxes and new contacts, copied into
//                          plain arrays                (depends on: frame N-1)
//   2. tasks     workers   sound, AI and any added task, each reading only
//                          the snapshot                (depends on: 1)
//   3. physics   main      Bullet's step, all K substeps: update, search,
//                          narrowphase, solver, integrate
//                                                      (depends on: 1, which
//                          must copy the state before the step changes it)
//   4. join      main      wait for every task         (depends on: 2, 3)
// The tasks run beside the whole step.  Inside each substep the broadphase
// searches (on its CUDA stream, or on the CPU with oneTBB's threads) right
// before that substep's narrowphase, which needs its pairs: physics/ does
// that on its own and reports when; the scheduler only draws it.
// With `sync`, the same jobs run one after another on the main thread:
// snapshot, each task, physics.  Both orders give the same pairs, state and
// sound: the tasks only read the snapshot, and physics never reads the tasks.
//
// Threads: the main thread runs Bullet; oneTBB's workers run the tasks
// (first: their arena has the higher priority) and a CPU search.  A
// oneTBB thread cap of N (`overlap run --threads N`, tbb::global_control)
// leaves N - 1 workers, so the run uses N threads in all.  A main thread
// that waits (for a CPU search's threads, or for the tasks at the join) runs
// what nobody has taken yet, so no core idles while work is queued.
//
// A task that throws does not stop the frame: the step finishes, every task
// is joined, then runFrame() throws one error naming the task, the frame
// and the cause.  A step that throws still joins the tasks before the error
// leaves runFrame().
#pragma once

#include <oneapi/tbb/task_arena.h>
#include <oneapi/tbb/task_group.h>

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "audio_ai_stubs/ai.h"
#include "audio_ai_stubs/sound.h"
#include "audio_ai_stubs/wav_writer.h"
#include "engine/timeline.h"
#include "physics/world.h"

namespace overlap::engine {

struct SchedulerOptions {
  bool sync = false;  // run the jobs one after another instead of the tasks beside physics
  bool tasks = true;  // false: physics only (the paper's measurements)
  stubs::SoundConfig sound;
  stubs::AiConfig ai;
  OutputFile* wav = nullptr;  // the whole run's mix, finished by close(); the caller publishes it
};

// The tasks the scheduler adds itself, first, by these names.
inline constexpr std::string_view kSoundTask = "sound";
inline constexpr std::string_view kAiTask = "ai";

// One task's run in a frame, on whatever thread ran it.
struct TaskRun {
  std::string name;
  Interval run;
};

// What a frame's jobs did, as points on the steady clock; frames.csv and the
// timeline convert them where they write them.
struct ScheduledFrame {
  physics::FrameReport physics;
  Interval whole;  // the whole frame, snapshot to join
  Interval step;   // job 3, physics
  // Job 2 as one: launch to join beside the step, or with `sync` the first
  // task's start to the last one's end.  None without tasks.
  std::optional<Interval> tasks;
  std::optional<Interval> wait;    // the main thread waiting for the tasks (not with `sync`)
  std::vector<TaskRun> task_runs;  // in the order the tasks were added
  double tasks_hidden = 0;         // share of the tasks' time that ran beside the step

  // The named task's run; zero when it did not run.
  Clock::duration taskTime(std::string_view name) const;
  Clock::duration waitTime() const { return wait ? wait->length() : Clock::duration::zero(); }
};

class FrameScheduler {
 public:
  FrameScheduler(physics::PhysicsWorld& world, const SchedulerOptions& options, Timeline& timeline);
  ~FrameScheduler();

  // A game system of the caller's, run each frame as a task beside physics
  // (it must read only what the snapshot-taking caller gave it).
  void addTask(std::string name, std::function<void()> work);

  ScheduledFrame runFrame();
  // Finishes the WAV file, if any.
  void close();

  std::uint64_t soundChecksum() const { return sound_checksum_; }
  std::uint64_t aiChecksum() const;
  // The tasks' own work counters; null when the tasks are off.
  const stubs::SoundWork* soundWork() const { return sound_ ? &sound_->work() : nullptr; }
  const stubs::AiWork* aiWork() const { return ai_ ? &ai_->work() : nullptr; }

 private:
  struct Task {
    std::string name;
    std::function<void()> work;
    Interval run{};     // this frame's
    std::string error;  // this frame's, empty if none
  };
  class TasksBeside;

  void snapshot();
  void runSound();
  void runAi();
  void runTask(Task& task);
  // The tasks' runs and how much of them the step hid, into `frame`.
  void measureTasks(ScheduledFrame& frame) const;

  physics::PhysicsWorld& world_;
  SchedulerOptions options_;
  Timeline& timeline_;
  std::unique_ptr<stubs::SoundMixer> sound_;
  std::unique_ptr<stubs::AgentCrowd> ai_;
  std::unique_ptr<stubs::WavWriter> wav_;
  std::vector<stubs::ImpactEvent> impacts_;
  std::vector<stubs::Obstacle> obstacles_;
  std::uint64_t sound_checksum_;
  int frame_ = 0;
  // Each task writes only its own entry while it runs.
  std::vector<Task> tasks_;
  // High priority: the workers serve the tasks first.  Nobody else can run
  // them before the join, while the main thread searches alone when every
  // worker is busy (a CPU search's parallel loop has normal priority).
  tbb::task_arena arena_{tbb::task_arena::automatic, 1, tbb::task_arena::priority::high};
  tbb::task_group group_;
};

}  // namespace overlap::engine
