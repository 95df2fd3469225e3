// The asynchronous frame: one frame of the game loop this project is named
// for (engine/runtime/game_session.h steps it, frame after frame).
//
// A frame is a graph of named jobs (engine/runtime/job_graph.h) that the scheduler
// runs once per runFrame(): the physics step, which the scheduler adds
// itself, and the jobs other owners register (engine/runtime/sound_and_ai.h adds a
// snapshot, the sound and the AI).  For the demo's frame N:
//   snapshot  main     frame N-1's boxes and new contacts, copied into
//                      plain arrays                (after: frame N-1)
//   sound, ai workers  each reading only the snapshot
//                                                  (after: snapshot)
//   physics   main     Bullet's step, all K substeps: update, search,
//                      narrowphase, solver, integrate
//                                                  (after: every job added
//                      with addBeforeStep, which copies the state first)
//   join      main     wait for every task         (after: all of them)
// Rules, each with its reason:
// - Bullet is only ever called from the main thread: it is not thread-safe.
// - The tasks run beside the whole step.  Inside each substep the broadphase
//   searches (on its CUDA stream, or on the CPU with oneTBB's threads) right
//   before that substep's narrowphase, which needs its pairs: physics/ does
//   that on its own and reports when; the scheduler only draws it.
// - With `sync`, the same jobs run one after another on the main thread in
//   the order added (the demo: snapshot, sound, ai, physics).  Both orders
//   give the same pairs, state and sound: a task reads only what a job
//   before the step copied, and physics never reads the tasks.
// - Jobs are registered before the first frame: the step is added then,
//   after every job registered before it.
//
// Threads: the world's task system (gpu/task_system.h; `overlap run
// --threads N` makes one of N threads, the main thread among them) runs the
// tasks, the step's parallel parts and a CPU search, each on whichever
// thread is free.  A main thread that waits (for the step's pieces, or for
// the tasks at the join) runs what nobody has taken yet, so no core idles
// while work is queued.
//
// A task that throws does not stop the frame: the step finishes, every task
// is joined, then runFrame() throws one error naming the task, the frame
// and the cause.  A step that throws still joins the tasks before the error
// leaves runFrame().
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "engine/runtime/job_graph.h"
#include "engine/runtime/timeline.h"
#include "physics/world.h"

namespace overlap::engine {

struct SchedulerOptions {
  bool sync = false;  // run the jobs one after another instead of the tasks beside physics
};

// The timeline's name of the step's job.
inline constexpr std::string_view kPhysicsJob = "physics";

// One task's run in a frame, on whatever thread ran it.
struct TaskRun {
  std::string name;
  Interval run;
};

// What a frame's jobs did, as points on the steady clock; frames.csv and the
// timeline convert them where they write them.
struct ScheduledFrame {
  physics::FrameReport physics;
  Interval whole;  // the whole frame, first job to join
  Interval step;   // the physics step
  // The tasks as one: launch to join beside the step, or with `sync` the
  // first task's start to the last one's end.  None without tasks.
  std::optional<Interval> tasks;
  std::optional<Interval> wait;    // the main thread waiting for the tasks (not with `sync`)
  std::vector<TaskRun> task_runs;  // in the order the tasks were added
  double tasks_hidden = 0;         // share of the tasks' time that ran beside the step
  double cpu_ms = 0;  // CPU time of every thread over the frame (the step's and the tasks')

  // The named task's run; zero when it did not run.
  Clock::duration taskTime(std::string_view name) const;
  Clock::duration waitTime() const { return wait ? wait->length() : Clock::duration::zero(); }
};

class FrameScheduler {
 public:
  FrameScheduler(physics::PhysicsWorld& world, const SchedulerOptions& options, Timeline& timeline);
  ~FrameScheduler();

  // A job on the main thread before the step, which waits for it: it may
  // read the world, to copy what the tasks will read.  Registered before the
  // first frame (std::logic_error otherwise).
  JobId addBeforeStep(std::string name, std::function<void()> work);
  // A game system run each frame as a task beside the step, once the jobs
  // `after` have ended; it must read only what those jobs copied for it.
  // Registered before the first frame (std::logic_error otherwise).
  JobId addTask(std::string name, std::function<void()> work, std::vector<JobId> after = {});

  ScheduledFrame runFrame();

 private:
  void refuseAfterFirstFrame(const std::string& name) const;
  // The tasks' runs and how much of them the step hid, into `frame`.
  void measureTasks(ScheduledFrame& frame) const;

  physics::PhysicsWorld& world_;
  SchedulerOptions options_;
  Timeline& timeline_;
  JobGraph jobs_;
  std::vector<JobId> before_step_;
  std::vector<JobId> tasks_;
  std::optional<JobId> step_;  // added by the first frame
  physics::FrameReport step_report_;
  int frame_ = 0;
};

}  // namespace overlap::engine
