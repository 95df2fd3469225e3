#include "engine/frame_scheduler.h"

#include <algorithm>
#include <exception>
#include <stdexcept>

#include "physics/checksum.h"

namespace overlap::engine {
namespace {

// Box sizes map to impact pitch: a 1 m box rings at the base pitch.
float pitchHint(float edge) {
  return std::isfinite(edge) && edge > 0 ? 1.0f / edge : 1.0f;
}

double microseconds(double ms) {
  return ms * 1e3;
}

}  // namespace

// Job 2 beside job 3: the tasks start on the workers when this is made and
// are joined (job 4) when it goes, on every path out of the frame.
class FrameScheduler::TasksBeside {
 public:
  TasksBeside(FrameScheduler& scheduler, bool beside) : scheduler_(scheduler), beside_(beside) {
    if (!beside_) return;
    launched_ = scheduler_.now();
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
    if (!beside_ || joined_ >= 0) return;
    waited_ = scheduler_.now();
    scheduler_.arena_.execute([this] { scheduler_.group_.wait(); });  // runTask never throws
    joined_ = scheduler_.now();
  }
  double launched() const { return launched_; }
  double waited() const { return waited_; }
  double joined() const { return joined_; }

 private:
  FrameScheduler& scheduler_;
  bool beside_;
  double launched_ = -1, waited_ = -1, joined_ = -1;
};

FrameScheduler::FrameScheduler(physics::PhysicsWorld& world, const SchedulerOptions& options,
                               Timeline& timeline)
    : world_(world),
      options_(options),
      timeline_(timeline),
      sound_checksum_(physics::kFnv1aOffsetBasis) {
  if (!options_.tasks) return;
  options_.sound.frame_seconds = world.config().frame_time;
  options_.ai.frame_seconds = world.config().frame_time;
  sound_ = std::make_unique<stubs::SoundMixer>(options_.sound);
  ai_ = std::make_unique<stubs::AgentCrowd>(options_.ai,
                                            static_cast<float>(world.layout().half_extent));
  if (options_.wav) {
    wav_ = std::make_unique<stubs::WavWriter>(*options_.wav, options_.sound.sample_rate);
  }
  addTask("sound", [this] { runSound(); });
  addTask("ai", [this] { runAi(); });
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
    impacts_.push_back({contact.closing_speed, contact.pan, pitchHint(contact.edge)});
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
  sound_checksum_ = physics::fnv1a(sound_->mix(), sound_checksum_);
}

void FrameScheduler::runAi() {
  ai_->runFrame(obstacles_);
}

// Catches everything: an error is the frame's to report once all tasks and
// the step are done, and a task that throws must not cancel its siblings.
void FrameScheduler::runTask(Task& task) {
  task.error.clear();
  const double start = now();
  try {
    task.work();
  } catch (const std::exception& error) {
    task.error = error.what();
  } catch (...) {
    task.error = "an exception that is not a std::exception";
  }
  task.span = {start, now()};
}

// The frame's jobs, top to bottom (frame_scheduler.h draws the graph).
ScheduledFrame FrameScheduler::runFrame() {
  ScheduledFrame frame;
  const double frame_start = now();
  // 1. snapshot, main thread.  Depends on: frame N-1's step.
  if (!tasks_.empty()) snapshot();
  std::pair<double, double> tasks_job{-1, -1};
  double physics_start = 0;
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
    physics_start = now();
    frame.physics = world_.stepFrame();
    // 4. join, main thread.  Depends on: 2, 3.
    beside.join();
    if (!options_.sync) {
      tasks_job = {beside.launched(), beside.joined()};
      frame.tasks_wait_ms = (beside.joined() - beside.waited()) / 1e3;
    }
  }
  for (const Task& task : tasks_) {
    if (!task.error.empty()) {
      ++frame_;  // the step is done: the next frame is the next one
      throw std::runtime_error("task '" + task.name + "' failed in frame " +
                               std::to_string(frame_ - 1) + ": " + task.error);
    }
  }
  if (options_.sync && !tasks_.empty()) {
    tasks_job = {tasks_.front().span.first, tasks_.back().span.second};
  }
  frame.frame_ms = (now() - frame_start) / 1e3;
  drawFrame(frame, frame_start, tasks_job, physics_start);
  ++frame_;
  return frame;
}

void FrameScheduler::drawFrame(ScheduledFrame& frame, double frame_start,
                               std::pair<double, double> tasks_job, double physics_start) {
  auto addSpan = [&](const char* name, const char* lane, double start, double end,
                     int substep = -1) {
    timeline_.add(Span{name, lane, start, end, frame_, substep});
  };
  const physics::FrameReport& step = frame.physics;
  const double physics_end = physics_start + microseconds(step.timings.total_ms);
  addSpan("frame", "main", frame_start, frame_start + microseconds(frame.frame_ms));
  addSpan("physics", "main", physics_start, physics_end);
  for (std::size_t k = 0; k < step.substep_reports.size(); ++k) {
    const physics::SubstepReport& substep = step.substep_reports[k];
    const int index = static_cast<int>(k);
    const auto at = [&](Timeline::Clock::time_point t) { return timeline_.microsecondsAt(t); };
    addSpan("substep", "main", at(substep.start), at(substep.end), index);
    if (const auto& search = substep.search) {
      const double search_start = at(search->launched) + microseconds(search->start_delay_ms);
      addSpan("search", "broadphase", search_start, search_start + microseconds(search->search_ms),
              index);
      addSpan("join", "main", at(search->joined),
              at(search->joined) + microseconds(search->join_ms), index);
    }
    addSpan("narrowphase", "main", at(substep.narrowphase_start), at(substep.narrowphase_end),
            index);
  }
  if (tasks_.empty()) return;
  addSpan("tasks", "tasks", tasks_job.first, tasks_job.second);
  double task_time = 0;
  double hidden = 0;
  for (const Task& task : tasks_) {
    const double duration = task.span.second - task.span.first;
    addSpan(task.name.c_str(), task.name.c_str(), task.span.first, task.span.second);
    task_time += duration;
    hidden += duration * coveredShare(task.span.first, duration, {{physics_start, physics_end}});
  }
  if (!options_.sync) {
    const double wait = microseconds(frame.tasks_wait_ms);
    addSpan("wait for tasks", "main", tasks_job.second - wait, tasks_job.second);
  }
  if (sound_) {  // then tasks_ opens with sound and AI
    frame.sound_ms = (tasks_[0].span.second - tasks_[0].span.first) / 1e3;
    frame.ai_ms = (tasks_[1].span.second - tasks_[1].span.first) / 1e3;
  }
  frame.tasks_hidden = task_time > 0 ? hidden / task_time : 0.0;
}

}  // namespace overlap::engine
