// --task-load X: the sound and AI tasks sized so that, together, they cost
// about X times the physics step of the run's scene, n and broadphase.
//
// The rule, measured once before the run: a scratch copy of the scene runs
// its first kCalibrationFrames frames with the tasks at their default sizes,
// one job after another on the main thread (--sync).  From the medians over
// those frames: P, the physics step; the sound task's cost per sounding
// voice; the AI task's cost per agent.  Each task then gets X * P / 2: sound
// as that many always-sounding (background) voices plus a pool of up to 8
// voices for impacts, AI as that many agents.  X = 0 means no voices and no
// agents: the tasks are scheduled and do nothing.  Early frames are cheaper
// than a settled pile, so the ratio the run actually measures (task time
// over physics time, in summary.json) is what a study should plot against.
#pragma once

#include <nlohmann/json.hpp>

#include "audio_ai_stubs/ai.h"
#include "audio_ai_stubs/sound.h"
#include "physics/world.h"

namespace overlap::engine {

struct TaskLoadCalibration {
  double physics_ms = 0;          // P: the median physics step of the scratch frames
  double sound_ms_per_voice = 0;  // per sounding voice per frame
  double ai_ms_per_agent = 0;     // per agent per frame
  int voices = 0;                 // what X gives
  int background_voices = 0;
  int agents = 0;
};

inline constexpr int kCalibrationFrames = 6;
inline constexpr int kImpactVoicePool = 8;

// Measures the scene and sizes `sound` and `ai` for `load` (>= 0).
TaskLoadCalibration calibrateTaskLoad(double load, const physics::SceneConfig& config,
                                      const physics::WorldOptions& world_options,
                                      stubs::SoundConfig& sound, stubs::AiConfig& ai);

nlohmann::json toJson(const TaskLoadCalibration& calibration);

}  // namespace overlap::engine
