#include "engine/frame_scheduler.h"

#include <algorithm>
#include <exception>
#include <stdexcept>

#include "gpu/base/checksum.h"
#include "gpu/base/interrupt.h"

namespace overlap::engine {
namespace {

// A new contact as the sound hears it: panned by where the box was across the
// container (-1 left .. 1 right), pitched by its size (a 1 m box rings at the
// base pitch).
stubs::ImpactEvent impactOf(const physics::NewContact& contact, double half_extent) {
  const float pan = static_cast<float>(std::clamp(contact.centre[0] / half_extent, -1.0, 1.0));
  const float edge = contact.edge;
  const float pitch_hint = std::isfinite(edge) && edge > 0 ? 1.0f / edge : 1.0f;
  return {contact.closing_speed, pan, pitch_hint};
}

// The frame's jobs on the timeline, each substep's search, join and
// narrowphase among them.
void drawFrame(const ScheduledFrame& frame, int index, Timeline& timeline) {
  const auto add = [&](std::string_view name, std::string_view lane, const Interval& at,
                       int substep = -1) {
    timeline.add(Span{std::string(name), std::string(lane), at, index, substep});
  };
  add("frame", "main", frame.whole);
  add("physics", "main", frame.step);
  const std::vector<physics::SubstepReport>& substeps = frame.physics.substep_reports;
  for (std::size_t k = 0; k < substeps.size(); ++k) {
    const physics::SubstepReport& substep = substeps[k];
    const int at = static_cast<int>(k);
    add("substep", "main", {substep.start, substep.end}, at);
    if (const auto& search = substep.search) {
      add("search", "broadphase", {search->started, search->started + search->searched}, at);
      add("join", "main", {search->joined, search->finished}, at);
    }
    add("narrowphase", "main", {substep.narrowphase_start, substep.narrowphase_end}, at);
  }
  if (frame.tasks) add("tasks", "tasks", *frame.tasks);
  for (const TaskRun& task : frame.task_runs) add(task.name, task.name, task.run);
  if (frame.wait) add("wait for tasks", "main", *frame.wait);
}

}  // namespace

// Job 2 beside job 3: the tasks start on the workers when this is made and
// are joined (job 4) when it goes, on every path out of the frame.
class FrameScheduler::TasksBeside {
 public:
  TasksBeside(FrameScheduler& scheduler, bool beside) : scheduler_(scheduler), beside_(beside) {
    if (!beside_) return;
    launched_ = Clock::now();
    scheduler_.arena_.execute([this] {
      for (Task& task : scheduler_.tasks_) {
        scheduler_.group_.run([this, &task] { scheduler_.runTask(task); });
      }
    });
  }
  TasksBeside(const TasksBeside&) = delete;
  TasksBeside& operator=(const TasksBeside&) = delete;
  ~TasksBeside() { join(); }

  // Waits for every task: the main thread runs any task no worker has taken.
  void join() {
    if (!beside_ || joined_) return;
    wait_.start = Clock::now();
    scheduler_.arena_.execute([this] { scheduler_.group_.wait(); });  // runTask never throws
    wait_.end = Clock::now();
    joined_ = true;
  }
  // Launch to join, and the wait at the join; none when the tasks ran elsewhere.
  std::optional<Interval> job() const {
    return beside_ ? std::optional(Interval{launched_, wait_.end}) : std::nullopt;
  }
  std::optional<Interval> wait() const { return beside_ ? std::optional(wait_) : std::nullopt; }

 private:
  FrameScheduler& scheduler_;
  bool beside_;
  bool joined_ = false;
  Clock::time_point launched_;
  Interval wait_;
};

FrameScheduler::FrameScheduler(physics::PhysicsWorld& world, const SchedulerOptions& options,
                               Timeline& timeline)
    : world_(world), options_(options), timeline_(timeline), sound_checksum_(kFnv1aOffsetBasis) {
  if (!options_.tasks) return;
  options_.sound.frame_seconds = world.config().frame_time;
  options_.ai.frame_seconds = world.config().frame_time;
  sound_ = std::make_unique<stubs::SoundMixer>(options_.sound);
  ai_ = std::make_unique<stubs::AgentCrowd>(options_.ai,
                                            static_cast<float>(world.layout().half_extent));
  if (options_.wav) {
    wav_ = std::make_unique<stubs::WavWriter>(*options_.wav, options_.sound.sample_rate);
  }
  addTask(std::string(kSoundTask), [this] { runSound(); });
  addTask(std::string(kAiTask), [this] { runAi(); });
}

FrameScheduler::~FrameScheduler() = default;

void FrameScheduler::addTask(std::string name, std::function<void()> work) {
  tasks_.push_back(Task{std::move(name), std::move(work), {}, {}});
}

void FrameScheduler::close() {
  if (wav_) wav_->close();
}

std::uint64_t FrameScheduler::aiChecksum() const {
  return ai_ ? ai_->checksum() : 0;
}

// Job 1: what the tasks may read, copied while nothing else runs.  Boxes out
// of the simulation are in neither list (PhysicsWorld leaves them out).
void FrameScheduler::snapshot() {
  impacts_.clear();
  for (const physics::NewContact& contact : world_.newContacts()) {
    impacts_.push_back(impactOf(contact, world_.layout().half_extent));
  }
  obstacles_.clear();
  for (const physics::BoxPose& pose : world_.boxPoses()) {
    obstacles_.push_back({Eigen::Vector3f(pose.centre[0], pose.centre[1], pose.centre[2]),
                          pose.edge * 0.8660254f});  // the box's bounding sphere
  }
}

void FrameScheduler::runSound() {
  sound_->runFrame(impacts_);
  if (wav_) sound_->appendMixTo(*wav_);
  sound_checksum_ = fnv1a(sound_->mix(), sound_checksum_);
}

void FrameScheduler::runAi() {
  ai_->runFrame(obstacles_);
}

// Catches everything: an error is the frame's to report once all tasks and
// the step are done, and a task that throws must not cancel its siblings.
void FrameScheduler::runTask(Task& task) {
  task.error.clear();
  const Clock::time_point start = Clock::now();
  try {
    task.work();
  } catch (const std::exception& error) {
    task.error = error.what();
  } catch (...) {
    task.error = "an exception that is not a std::exception";
  }
  task.run = {start, Clock::now()};
}

// The frame's jobs, top to bottom (frame_scheduler.h draws the graph).
ScheduledFrame FrameScheduler::runFrame() {
  ScheduledFrame frame;
  frame.whole.start = Clock::now();
  // 1. snapshot, main thread.  Depends on: frame N-1's step.
  if (!tasks_.empty()) snapshot();
  {
    // 2. tasks.  Depends on: 1.  Async: on the workers from here on, and
    // joined when `beside` goes, whichever way this block is left.
    TasksBeside beside(*this, !options_.sync && !tasks_.empty());
    if (options_.sync) {
      for (Task& task : tasks_) runTask(task);  // sync: here, one after another
    }
    // 3. physics, main thread.  Depends on: 1 (the snapshot copied the state
    // the step changes).  Every substep's search is launched and joined
    // inside, before that substep's narrowphase.
    frame.step.start = Clock::now();
    frame.physics = world_.stepFrame();
    frame.step.end = Clock::now();
    // 4. join, main thread.  Depends on: 2, 3.
    beside.join();
    frame.tasks = beside.job();
    frame.wait = beside.wait();
  }
  for (const Task& task : tasks_) {
    if (!task.error.empty()) {
      // A signal that stopped a task's write (a --wav FIFO's slow reader)
      // is the run's stop, not the task's failure.
      stopIfInterrupted("frame " + std::to_string(frame_));
      ++frame_;  // the step is done: the next frame is the next one
      throw std::runtime_error("task '" + task.name + "' failed in frame " +
                               std::to_string(frame_ - 1) + ": " + task.error);
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
  if (options_.sync) frame.tasks = Interval{tasks_.front().run.start, tasks_.back().run.end};
  Clock::duration task_time{};
  Clock::duration hidden{};
  for (const Task& task : tasks_) {
    frame.task_runs.push_back(TaskRun{task.name, task.run});
    task_time += task.run.length();
    hidden += overlapOf(task.run, frame.step);
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
