// --task-load X: the sound and AI tasks sized so that, together, they cost
// about X times the physics step of the run's scene, n and broadphase.
//
// The rule, measured once before the run:
//   P      the median physics step over the run's first min(frames, 64)
//          frames, stepped physics-only on a scratch copy of the scene (the
//          same frames the run will make: the physics is deterministic);
//   sizes  each task gets X * P / 2: sound as that many always-sounding
//          voices (plus a pool of up to 8 for impacts), AI as that many
//          agents among the scratch scene's last boxes.  A task's cost is
//          timed at a guessed size and the size corrected, up to five
//          times, assuming cost ~ size^k with k measured from the last two
//          guesses (the AI's cost grows faster than its agent count, as
//          agents crowd each other).
// A signal stops the calibration between two frames (Interrupted), and the
// caller shows its progress (it can take a minute at large X).
// No size goes past its bound: a task that costs less than its share even
// there is named in `beyond_bound` (the command refuses that X).
// X = 0 gives no voices and no agents: the tasks are scheduled and do
// nothing.  The measured task time over the physics time of the run itself
// (summary.json, and the study's `T/P measured`) is what to plot against.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "audio_ai_stubs/ai.h"
#include "audio_ai_stubs/sound.h"
#include "physics/world.h"

namespace overlap::engine {

struct TaskLoadCalibration {
  int physics_frames = 0;  // scratch frames stepped
  double physics_ms = 0;   // P: their median physics step
  double sound_ms = 0;     // the sound task at the chosen size, as timed
  double ai_ms = 0;        // the AI task at the chosen size, as timed
  int voices = 0;          // what X gives
  int background_voices = 0;
  int agents = 0;
  // "sound" or "AI": the task whose bound (kMostVoices, kMostAgents) costs
  // less than its share, which X then cannot be; empty when both fit.
  std::string beyond_bound;
};

// The documented bounds of the task sizes (docs/CLI.md), given by hand
// (--voices, --agents) or calibrated: a voice or an agent costs a few
// hundred bytes and its share of every frame.
inline constexpr int kMostVoices = 100'000;
inline constexpr int kMostAgents = 100'000;

inline constexpr int kMostCalibrationFrames = 64;
inline constexpr int kImpactVoicePool = 8;

// Measures the scene and sizes `sound` and `ai` for `load` (>= 0) over a run
// of `frames` frames.
TaskLoadCalibration calibrateTaskLoad(double load, int frames, const physics::SceneConfig& config,
                                      const physics::WorldOptions& world_options,
                                      stubs::SoundConfig& sound, stubs::AiConfig& ai);

nlohmann::json toJson(const TaskLoadCalibration& calibration);

}  // namespace overlap::engine
