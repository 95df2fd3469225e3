#include "engine/runtime/task_load.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "engine/runtime/statistics.h"
#include "gpu/base/interrupt.h"
#include "gpu/base/stopwatch.h"

namespace overlap::engine {
namespace {

constexpr int kTimedFrames = 3;  // frames timed per guess
constexpr int kRescales = 5;     // guesses after the first
constexpr double kClose = 0.05;  // a guess this close to the budget is kept

// The count, at most `most`, whose cost (ms per frame, measured by `cost`) is
// about `budget_ms`, starting from `guess`: each next guess assumes cost ~
// count^k, with k measured from the last two guesses (first 1.25: a crowd's
// cost grows faster than its size, and overshooting it is what takes long).
int sizeToBudget(double budget_ms, int guess, int most, const std::function<double(int)>& cost,
                 double& cost_ms) {
  cost_ms = 0;
  if (budget_ms <= 0) return 0;
  int count = std::clamp(guess, 1, most);
  cost_ms = cost(count);
  double exponent = 1.25;
  for (int attempt = 0; attempt < kRescales; ++attempt) {
    if (cost_ms <= 0 || std::fabs(cost_ms / budget_ms - 1) < kClose) break;
    const double wanted = count * std::pow(budget_ms / cost_ms, 1 / exponent);
    const int next = static_cast<int>(std::lround(std::clamp(wanted, 1.0, double(most))));
    if (next == count) break;
    const double next_ms = cost(next);
    if (next_ms > 0 && cost_ms > 0) {
      exponent = std::clamp(std::log(next_ms / cost_ms) / std::log(double(next) / count), 0.5, 3.0);
    }
    count = next;
    cost_ms = next_ms;
  }
  return count;
}

// The median of kTimedFrames frames; just the first when it is already far
// over `budget_ms` (a guess that large is only there to be corrected).
double frameMs(double budget_ms, const std::function<void()>& frame) {
  std::vector<double> times;
  for (int i = 0; i < kTimedFrames; ++i) {
    stopIfInterrupted("timing a task");
    const HostStopwatch watch;
    frame();
    times.push_back(watch.ms());
    if (times.front() > 4 * budget_ms) break;
  }
  return median(times);
}

}  // namespace

namespace {

TaskLoadCalibration calibrate(double load, int frames, const physics::SceneConfig& config,
                              const physics::WorldOptions& world_options, stubs::SoundConfig& sound,
                              stubs::AiConfig& ai) {
  TaskLoadCalibration result;
  physics::PhysicsWorld world(config, world_options);
  result.physics_frames = std::min(frames, kMostCalibrationFrames);
  std::vector<double> physics_ms;
  for (int frame = 0; frame < result.physics_frames; ++frame) {
    stopIfInterrupted("physics frame " + std::to_string(frame) + " of " +
                      std::to_string(result.physics_frames));
    physics_ms.push_back(world.stepFrame().timings.total_ms);
  }
  result.physics_ms = median(physics_ms);
  const double budget_ms = load * result.physics_ms / 2;  // each task's share

  stubs::SoundConfig sound_config = sound;
  sound_config.frame_seconds = config.frame_time;
  // The impacts' pool comes on top of the always-sounding voices.
  const int most_background = kMostVoices - kImpactVoicePool;
  result.background_voices = sizeToBudget(
      budget_ms, stubs::SoundConfig{}.voices, most_background,
      [&](int voices) {
        sound_config.voices = sound_config.background_voices = voices;
        stubs::SoundMixer mixer(sound_config);
        return frameMs(budget_ms, [&] { mixer.runFrame({}); });
      },
      result.sound_ms);
  result.voices = result.background_voices + std::min(kImpactVoicePool, result.background_voices);
  if (result.background_voices == most_background && result.sound_ms < budget_ms * (1 - kClose)) {
    result.beyond_bound = "sound";
  }

  std::vector<stubs::Obstacle> obstacles;
  for (const physics::BoxPose& pose : world.boxPoses()) {
    obstacles.push_back(
        {Eigen::Vector3f(pose.centre[0], pose.centre[1], pose.centre[2]), pose.edge * 0.8660254f});
  }
  stubs::AiConfig ai_config = ai;
  ai_config.frame_seconds = config.frame_time;
  const auto half_extent = static_cast<float>(world.layout().half_extent);
  result.agents = sizeToBudget(
      budget_ms, stubs::AiConfig{}.agents, kMostAgents,
      [&](int agents) {
        ai_config.agents = agents;
        stubs::AgentCrowd crowd(ai_config, half_extent);
        return frameMs(budget_ms, [&] { crowd.runFrame(obstacles); });
      },
      result.ai_ms);
  if (result.beyond_bound.empty() && result.agents == kMostAgents &&
      result.ai_ms < budget_ms * (1 - kClose)) {
    result.beyond_bound = "AI";
  }

  sound.voices = result.voices;
  sound.background_voices = result.background_voices;
  ai.agents = result.agents;
  return result;
}

}  // namespace

TaskLoadCalibration calibrateTaskLoad(double load, int frames, const physics::SceneConfig& config,
                                      const physics::WorldOptions& world_options,
                                      stubs::SoundConfig& sound, stubs::AiConfig& ai) {
  try {
    return calibrate(load, frames, config, world_options, sound, ai);
  } catch (const Interrupted& stop) {  // said as the calibration, not as the run's frame
    throw Interrupted(stop.signal, "the --task-load calibration, " + stop.where);
  }
}

nlohmann::json toJson(const TaskLoadCalibration& calibration) {
  return {{"physics_frames", calibration.physics_frames},
          {"physics_ms", calibration.physics_ms},
          {"sound_ms", calibration.sound_ms},
          {"ai_ms", calibration.ai_ms},
          {"voices", calibration.voices},
          {"background_voices", calibration.background_voices},
          {"agents", calibration.agents}};
}

}  // namespace overlap::engine
