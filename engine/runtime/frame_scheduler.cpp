#include "engine/runtime/frame_scheduler.h"

#include <ctime>
#include <stdexcept>

#include "gpu/base/interrupt.h"

namespace overlap::engine {
namespace {

// The CPU time of every thread of the process so far, ms.
double processCpuMs() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) * 1e3 + static_cast<double>(now.tv_nsec) * 1e-6;
}

// The frame's jobs on the timeline, each substep's pair search and
// narrowphase among them.
void drawFrame(const ScheduledFrame& frame, int index, Timeline& timeline) {
  const auto add = [&](std::string_view name, std::string_view lane, const Interval& at,
                       int substep = -1) {
    timeline.add(Span{std::string(name), std::string(lane), at, index, substep});
  };
  add("frame", "main", frame.whole);
  add(kPhysicsJob, "main", frame.step);
  const std::vector<physics::SubstepReport>& substeps = frame.physics.substep_reports;
  for (std::size_t k = 0; k < substeps.size(); ++k) {
    const physics::SubstepReport& substep = substeps[k];
    const int at = static_cast<int>(k);
    add("substep", "main", {substep.start, substep.end}, at);
    if (substep.search_beside) {
      // The search on a lane of its own (a CPU finder's job, or the device),
      // the main thread's wait for it inside the narrowphase.
      add("broadphase", "search", {substep.broadphase_start, substep.search_end}, at);
      add("wait for search", "main", {substep.search_wait, substep.search_end}, at);
    } else {
      add("broadphase", "main", {substep.broadphase_start, substep.narrowphase_start}, at);
    }
    add("narrowphase", "main", {substep.narrowphase_start, substep.narrowphase_end}, at);
  }
  if (frame.tasks) add("tasks", "tasks", *frame.tasks);
  for (const TaskRun& task : frame.task_runs) add(task.name, task.name, task.run);
  if (frame.wait) add("wait for tasks", "main", *frame.wait);
}

}  // namespace

FrameScheduler::FrameScheduler(physics::PhysicsWorld& world, const SchedulerOptions& options,
                               Timeline& timeline)
    : world_(world), options_(options), timeline_(timeline), jobs_(world.tasks()) {}

FrameScheduler::~FrameScheduler() = default;

void FrameScheduler::refuseAfterFirstFrame(const std::string& name) const {
  if (step_) {
    throw std::logic_error("job '" + name + "' registered after the first frame: the step " +
                           "was added then, after every job before it");
  }
}

JobId FrameScheduler::addBeforeStep(std::string name, std::function<void()> work) {
  refuseAfterFirstFrame(name);
  const JobId job = jobs_.add(std::move(name), JobThread::kMain, std::move(work));
  before_step_.push_back(job);
  return job;
}

JobId FrameScheduler::addTask(std::string name, std::function<void()> work,
                              std::vector<JobId> after) {
  refuseAfterFirstFrame(name);
  const JobId job =
      jobs_.add(std::move(name), JobThread::kWorkers, std::move(work), std::move(after));
  tasks_.push_back(job);
  return job;
}

ScheduledFrame FrameScheduler::runFrame() {
  if (!step_) {
    step_ = jobs_.add(
        std::string(kPhysicsJob), JobThread::kMain, [this] { step_report_ = world_.stepFrame(); },
        before_step_);
  }
  ScheduledFrame frame;
  frame.whole.start = Clock::now();
  const double cpu_start = processCpuMs();
  jobs_.run(options_.sync);  // a step that throws leaves here, the tasks joined
  frame.cpu_ms = processCpuMs() - cpu_start;
  frame.physics = std::move(step_report_);
  frame.step = jobs_.lastRun(*step_);
  frame.tasks = jobs_.lastWorkers();
  frame.wait = jobs_.lastJoin();
  for (const JobId task : tasks_) {
    if (!jobs_.lastError(task).empty()) {
      // A signal that stopped a task's work (a --wav FIFO's slow reader) is
      // the run's stop, not the task's failure.
      stopIfInterrupted("frame " + std::to_string(frame_));
      ++frame_;  // the step is done: the next frame is the next one
      throw std::runtime_error("task '" + jobs_.name(task) + "' failed in frame " +
                               std::to_string(frame_ - 1) + ": " + jobs_.lastError(task));
    }
  }
  frame.whole.end = Clock::now();
  measureTasks(frame);
  drawFrame(frame, frame_, timeline_);
  ++frame_;
  return frame;
}

void FrameScheduler::measureTasks(ScheduledFrame& frame) const {
  if (tasks_.empty()) return;
  if (options_.sync) {
    frame.tasks = Interval{jobs_.lastRun(tasks_.front()).start, jobs_.lastRun(tasks_.back()).end};
  }
  Clock::duration task_time{};
  Clock::duration hidden{};
  for (const JobId task : tasks_) {
    const Interval& run = jobs_.lastRun(task);
    frame.task_runs.push_back(TaskRun{jobs_.name(task), run});
    task_time += run.length();
    hidden += overlapOf(run, frame.step);
  }
  frame.tasks_hidden =
      task_time > Clock::duration::zero() ? std::chrono::duration<double>(hidden) / task_time : 0.0;
}

Clock::duration ScheduledFrame::taskTime(std::string_view name) const {
  for (const TaskRun& task : task_runs) {
    if (task.name == name) return task.run.length();
  }
  return Clock::duration::zero();
}

}  // namespace overlap::engine
