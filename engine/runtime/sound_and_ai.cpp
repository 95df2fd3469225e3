#include "engine/runtime/sound_and_ai.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "gpu/base/checksum.h"

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

// A task's config, its frame as long as the world's.
template <typename Config>
Config forFramesOf(Config config, const physics::PhysicsWorld& world) {
  config.frame_seconds = world.config().frame_time;
  return config;
}

}  // namespace

SoundAndAi::SoundAndAi(const physics::PhysicsWorld& world, SoundAndAiOptions options,
                       FrameScheduler& scheduler)
    : world_(world),
      sound_(forFramesOf(options.sound, world)),
      ai_(forFramesOf(options.ai, world), static_cast<float>(world.layout().half_extent)),
      sound_checksum_(kFnv1aOffsetBasis) {
  if (options.wav != nullptr) {
    wav_ = std::make_unique<stubs::WavWriter>(*options.wav, options.sound.sample_rate);
  }
  const JobId copied = scheduler.addBeforeStep(std::string(kSnapshotJob), [this] { snapshot(); });
  scheduler.addTask(std::string(kSoundTask), [this] { runSound(); }, {copied});
  scheduler.addTask(std::string(kAiTask), [this] { ai_.runFrame(obstacles_); }, {copied});
}

SoundAndAi::~SoundAndAi() = default;

void SoundAndAi::close() {
  if (wav_) wav_->close();
}

void SoundAndAi::snapshot() {
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

void SoundAndAi::runSound() {
  sound_.runFrame(impacts_);
  if (wav_) sound_.appendMixTo(*wav_);
  sound_checksum_ = fnv1a(sound_.mix(), sound_checksum_);
}

}  // namespace overlap::engine
