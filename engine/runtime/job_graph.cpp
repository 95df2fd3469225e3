#include "engine/runtime/job_graph.h"

#include <exception>
#include <stdexcept>

namespace overlap::engine {

// Waits for every started worker job when it goes, on every path out of
// run(): nothing a job writes is read before its end.
class JobGraph::Join {
 public:
  explicit Join(JobGraph& graph) : graph_(graph) {}
  Join(const Join&) = delete;
  Join& operator=(const Join&) = delete;
  ~Join() { wait(); }

  void wait() {
    if (waited_) return;
    waited_ = true;
    if (!graph_.first_launch_) return;  // nothing started beside the main chain
    const Clock::time_point start = Clock::now();
    graph_.group_->wait();  // runCaught never throws
    graph_.join_ = Interval{start, Clock::now()};
    graph_.workers_ = Interval{*graph_.first_launch_, graph_.join_->end};
  }

 private:
  JobGraph& graph_;
  bool waited_ = false;
};

JobGraph::JobGraph(TaskSystem& tasks) : group_(tasks.makeGroup()) {}

JobGraph::~JobGraph() = default;

JobId JobGraph::add(std::string name, JobThread thread, std::function<void()> body,
                    std::vector<JobId> after) {
  const JobId id = jobs_.size();
  for (const JobId dependency : after) {
    if (dependency >= id) {
      throw std::invalid_argument("job '" + name + "' depends on a job not yet added");
    }
    if (thread == JobThread::kMain && jobs_[dependency]->thread == JobThread::kWorkers) {
      throw std::invalid_argument("main-thread job '" + name + "' depends on worker job '" +
                                  jobs_[dependency]->name +
                                  "': the main thread waits for workers only at the join");
    }
  }
  auto job = std::make_unique<Job>();
  job->name = std::move(name);
  job->thread = thread;
  job->body = std::move(body);
  job->dependencies = after.size();
  for (const JobId dependency : after) jobs_[dependency]->dependents.push_back(id);
  jobs_.push_back(std::move(job));
  return id;
}

// Catches everything: a worker job's error is the caller's to report once
// the join is done, and one that throws must not cancel its siblings.
void JobGraph::runCaught(Job& job) {
  job.error.clear();
  const Clock::time_point start = Clock::now();
  try {
    job.body();
  } catch (const std::exception& error) {
    job.error = error.what();
  } catch (...) {
    job.error = "an exception that is not a std::exception";
  }
  job.run = {start, Clock::now()};
}

void JobGraph::runOnMain(Job& job) {
  const Clock::time_point start = Clock::now();
  job.body();
  job.run = {start, Clock::now()};
}

// The main thread's first launch of a run marks where the workers' span
// starts; a worker launches only after it.
void JobGraph::launch(JobId id, bool from_main) {
  if (from_main && !first_launch_) first_launch_ = Clock::now();
  group_->run([this, id] {
    runCaught(*jobs_[id]);
    ended(id, false);
  });
}

// The job's worker dependents whose last dependency this was start now (a
// main dependent's turn comes in the main chain's order).
void JobGraph::ended(JobId id, bool on_main) {
  for (const JobId dependent : jobs_[id]->dependents) {
    Job& job = *jobs_[dependent];
    if (job.waiting.fetch_sub(1) == 1 && job.thread == JobThread::kWorkers) {
      launch(dependent, on_main);
    }
  }
}

void JobGraph::run(bool sync) {
  workers_.reset();
  join_.reset();
  first_launch_.reset();
  for (const std::unique_ptr<Job>& job : jobs_) {
    job->waiting.store(job->dependencies);
    job->error.clear();
  }
  if (sync) {
    for (const std::unique_ptr<Job>& job : jobs_) {
      if (job->thread == JobThread::kWorkers) {
        runCaught(*job);
      } else {
        runOnMain(*job);
      }
    }
    return;
  }
  Join join(*this);
  for (JobId id = 0; id < jobs_.size(); ++id) {
    const Job& job = *jobs_[id];
    if (job.thread == JobThread::kWorkers && job.dependencies == 0) launch(id, true);
  }
  for (JobId id = 0; id < jobs_.size(); ++id) {
    Job& job = *jobs_[id];
    if (job.thread != JobThread::kMain) continue;
    runOnMain(job);  // a throw leaves through `join`
    ended(id, true);
  }
  join.wait();
}

}  // namespace overlap::engine
