#include "engine/frame_scheduler.h"

#include <oneapi/tbb/task_group.h>

#include <algorithm>

#include "audio_ai_stubs/checksum.h"

namespace overlap::engine {
namespace {

// Box sizes map to impact pitch: a 1 m box rings at the base pitch.
float pitchHint(float edge) {
  return std::isfinite(edge) && edge > 0 ? 1.0f / edge : 1.0f;
}

}  // namespace

FrameScheduler::FrameScheduler(physics::PhysicsWorld& world, const SchedulerOptions& options,
                               Timeline& timeline)
    : world_(world),
      options_(options),
      timeline_(timeline),
      sound_checksum_(stubs::kFnv1aOffsetBasis) {
  if (!options_.tasks) return;
  options_.sound.frame_seconds = world.config().frame_time;
  options_.ai.frame_seconds = world.config().frame_time;
  sound_ = std::make_unique<stubs::SoundMixer>(options_.sound);
  ai_ = std::make_unique<stubs::AgentCrowd>(options_.ai,
                                            static_cast<float>(world.layout().half_extent));
  if (options_.wav) {
    wav_ = std::make_unique<stubs::WavWriter>(options_.wav->string(), options_.sound.sample_rate);
  }
}

FrameScheduler::~FrameScheduler() = default;

void FrameScheduler::close() {
  if (wav_) wav_->close();
}

std::uint64_t FrameScheduler::aiChecksum() const {
  return ai_ ? ai_->checksum() : 0;
}

// Job 1: what the tasks may read, copied while nothing else runs.
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
  const double start = timeline_.microsecondsAt(Timeline::Clock::now());
  sound_->runFrame(impacts_);
  if (wav_) sound_->appendMixTo(*wav_);
  sound_checksum_ = stubs::fnv1a(sound_->mix(), sound_checksum_);
  sound_span_ = {start, timeline_.microsecondsAt(Timeline::Clock::now())};
}

void FrameScheduler::runAi() {
  const double start = timeline_.microsecondsAt(Timeline::Clock::now());
  ai_->runFrame(obstacles_);
  ai_span_ = {start, timeline_.microsecondsAt(Timeline::Clock::now())};
}

// Job 4, and the tasks' half of job 5: the main thread joins by waiting on
// the task group (and lends a hand running the tasks meanwhile).
void FrameScheduler::runTasks() {
  if (options_.sync) {
    runSound();
    runAi();
    return;
  }
  tbb::task_group tasks;
  tasks.run([this] { runSound(); });
  tasks.run([this] { runAi(); });
  tasks.wait();
}

ScheduledFrame FrameScheduler::runFrame() {
  ScheduledFrame frame;
  const double frame_start = timeline_.microsecondsAt(Timeline::Clock::now());
  if (options_.tasks) snapshot();
  const physics::FrameWork work{[this] { runTasks(); }, !options_.sync};
  frame.physics = world_.stepFrame(options_.tasks ? &work : nullptr);

  const physics::FrameTimings& t = frame.physics.timings;
  auto addSpan = [&](const char* name, const char* lane, double start, double duration_us) {
    timeline_.add(Span{name, lane, start, duration_us, frame_});
  };
  addSpan("frame", "main", frame_start, t.total_ms * 1e3);
  if (options_.tasks) {
    addSpan("sound", "sound", sound_span_.first, sound_span_.second - sound_span_.first);
    addSpan("ai", "ai", ai_span_.first, ai_span_.second - ai_span_.first);
    frame.sound_ms = (sound_span_.second - sound_span_.first) / 1e3;
    frame.ai_ms = (ai_span_.second - ai_span_.first) / 1e3;
  }
  if (const auto& search = frame.physics.background_search) {
    const double started =
        timeline_.microsecondsAt(search->launched) + search->start_delay_ms * 1e3;
    frame.search_ms = search->search_ms;
    addSpan("search", "broadphase", started, search->search_ms * 1e3);
    addSpan("join", "main", timeline_.microsecondsAt(search->joined), search->join_ms * 1e3);
    frame.overlap_efficiency =
        options_.tasks && !options_.sync
            ? coveredShare(started, search->search_ms * 1e3, {sound_span_, ai_span_})
            : 0.0;
  }
  ++frame_;
  return frame;
}

}  // namespace overlap::engine
