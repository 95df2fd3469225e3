// Named jobs with their dependencies, run once per call of run(), in the
// style of Jolt's job system: a job is a name, a body and the jobs it
// depends on, and the graph knows nothing of what the bodies do (the frame's
// physics step, sound and AI are their owners' jobs, engine/runtime/frame_scheduler.h
// and engine/runtime/sound_and_ai.h).
//
// Rules, each with its reason:
// - A job depends only on jobs added before it: the graph can have no cycle,
//   and the order of adding is an order that keeps every dependency.
// - A job runs on the main thread (the one calling run()) or on the task
//   system's threads (gpu/task_system.h), the one set of threads that the
//   physics step's parallel parts and a CPU search use too.  Main jobs run
//   one after another in the order added.  A main job depends only on main
//   jobs (add() refuses a worker): the main thread never waits for a worker
//   before the join, so no worker stalls its chain.
// - A worker job starts once its last dependency has ended (at the start of
//   run() if it has none), from whichever thread ended that dependency; a
//   thread free of the step's pieces takes it.
// - run() returns only once every started worker job has ended (the join),
//   on every path out of it.  A main thread waiting at the join runs worker
//   jobs that no worker has taken yet, so no core idles while work is queued.
// - With `sync`, every job runs on the main thread in the order added, one
//   after another: the same dependencies hold, nothing runs beside anything.
// - A worker job that throws does not stop the others (its dependents still
//   run): its error is kept for the caller to read after run().  A main job
//   that throws stops the main chain; run() joins what was started, then
//   rethrows it.
// - A job's body writes only what it owns while it runs; its dependencies'
//   ends happen before its start (oneTBB's task hand-off orders them).
#pragma once

#include <atomic>
#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "engine/runtime/timeline.h"
#include "gpu/task_system.h"

namespace overlap::engine {

using JobId = std::size_t;

enum class JobThread {
  kMain,     // the thread that calls run(), in the order added
  kWorkers,  // the task system's threads, as soon as its dependencies have ended
};

class JobGraph {
 public:
  // Worker jobs run on `tasks`, which must outlive the graph.
  explicit JobGraph(TaskSystem& tasks);
  ~JobGraph();
  JobGraph(const JobGraph&) = delete;
  JobGraph& operator=(const JobGraph&) = delete;

  // Throws std::invalid_argument for a dependency not yet added, or a main
  // job that depends on a worker job.
  JobId add(std::string name, JobThread thread, std::function<void()> body,
            std::vector<JobId> after = {});
  // Runs every job once, as the rules above say.
  void run(bool sync);

  std::size_t size() const { return jobs_.size(); }
  const std::string& name(JobId job) const { return jobs_[job]->name; }
  JobThread thread(JobId job) const { return jobs_[job]->thread; }
  // The last run()'s: when the job ran, and its error (empty if none).
  const Interval& lastRun(JobId job) const { return jobs_[job]->run; }
  const std::string& lastError(JobId job) const { return jobs_[job]->error; }
  // The last run()'s worker jobs beside the main chain: from the first one's
  // launch to the join's end, and the main thread's wait at the join.  None
  // with `sync` or without worker jobs.
  const std::optional<Interval>& lastWorkers() const { return workers_; }
  const std::optional<Interval>& lastJoin() const { return join_; }

 private:
  struct Job {
    std::string name;
    JobThread thread;
    std::function<void()> body;
    std::vector<JobId> dependents;  // the jobs that name this one in `after`
    std::size_t dependencies = 0;
    std::atomic<std::size_t> waiting{0};  // this run's dependencies not yet ended
    Interval run{};
    std::string error;
  };
  class Join;

  void runCaught(Job& job);
  void runOnMain(Job& job);
  void launch(JobId job, bool from_main);
  void ended(JobId job, bool on_main);

  std::vector<std::unique_ptr<Job>> jobs_;
  std::optional<Clock::time_point> first_launch_;  // written by the main thread only
  std::optional<Interval> workers_, join_;
  std::unique_ptr<TaskGroup> group_;
};

}  // namespace overlap::engine
