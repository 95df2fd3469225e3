#include "engine/task_load.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "engine/frame_scheduler.h"
#include "engine/statistics.h"

namespace overlap::engine {

TaskLoadCalibration calibrateTaskLoad(double load, const physics::SceneConfig& config,
                                      const physics::WorldOptions& world_options,
                                      stubs::SoundConfig& sound, stubs::AiConfig& ai) {
  physics::PhysicsWorld world(config, world_options);
  SchedulerOptions options;
  options.sync = true;
  options.sound = stubs::SoundConfig{};  // the default sizes, whatever was asked
  options.sound.sample_rate = sound.sample_rate;
  options.ai = stubs::AiConfig{};
  Timeline timeline;
  FrameScheduler scheduler(world, options, timeline);
  std::vector<double> physics_ms, sound_ms, ai_ms;
  for (int frame = 0; frame < kCalibrationFrames; ++frame) {
    const ScheduledFrame measured = scheduler.runFrame();
    physics_ms.push_back(measured.physics.timings.total_ms);
    sound_ms.push_back(measured.sound_ms);
    ai_ms.push_back(measured.ai_ms);
  }
  const stubs::SoundWork& work = *scheduler.soundWork();
  stubs::SoundConfig as_run = options.sound;
  as_run.frame_seconds = config.frame_time;  // as the scheduler sets it
  const double samples_per_frame = as_run.samplesPerFrame();
  const double sounding_voices =
      static_cast<double>(work.voice_samples) / (samples_per_frame * kCalibrationFrames);

  TaskLoadCalibration result;
  result.physics_ms = median(physics_ms);
  result.sound_ms_per_voice = median(sound_ms) / std::max(1.0, sounding_voices);
  result.ai_ms_per_agent = median(ai_ms) / std::max(1, options.ai.agents);
  const double budget_ms = load * result.physics_ms / 2;  // each task's share
  result.background_voices = static_cast<int>(std::lround(budget_ms / result.sound_ms_per_voice));
  result.voices = result.background_voices + std::min(kImpactVoicePool, result.background_voices);
  result.agents = static_cast<int>(std::lround(budget_ms / result.ai_ms_per_agent));
  sound.voices = result.voices;
  sound.background_voices = result.background_voices;
  ai.agents = result.agents;
  return result;
}

nlohmann::json toJson(const TaskLoadCalibration& calibration) {
  return {{"frames", kCalibrationFrames},
          {"physics_ms", calibration.physics_ms},
          {"sound_ms_per_voice", calibration.sound_ms_per_voice},
          {"ai_ms_per_agent", calibration.ai_ms_per_agent},
          {"voices", calibration.voices},
          {"background_voices", calibration.background_voices},
          {"agents", calibration.agents}};
}

}  // namespace overlap::engine
