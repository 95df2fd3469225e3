// The sound and AI tasks of the frame: the owner of the sound mixer, the
// crowd AI and the WAV they write, and of the snapshot they read.  It
// registers three jobs with a FrameScheduler:
//   snapshot  main     frame N-1's new contacts as impacts and its boxes as
//                      obstacles, copied into plain arrays; before the step,
//                      which changes what it copies
//   sound     workers  mixes this frame's impacts (after: snapshot)
//   ai        workers  steers the agents around the obstacles (after: snapshot)
// Rules, each with its reason:
// - The tasks read only the snapshot and physics never reads the tasks, so
//   the frame gives the same pairs, state and sound whether they run beside
//   the step or before it (`sync`).
// - Boxes out of the simulation are in neither array (PhysicsWorld leaves
//   them out), so a NaN box never reaches the sound or the AI.
// - The sound checksum folds each frame's mix in frame order: the same run
//   gives the same checksum, whichever threads ran it.
// It lives in engine/, not audio_ai_stubs/: turning contacts into impacts needs the
// physics world, which the stubs do not link.
#pragma once

#include <cstdint>
#include <memory>
#include <string_view>
#include <vector>

#include "audio_ai_stubs/ai.h"
#include "audio_ai_stubs/sound.h"
#include "audio_ai_stubs/wav_writer.h"
#include "engine/runtime/frame_scheduler.h"
#include "physics/world.h"

namespace overlap::engine {

// The jobs' names, as frames.csv's columns and the timeline's lanes read them.
inline constexpr std::string_view kSnapshotJob = "snapshot";
inline constexpr std::string_view kSoundTask = "sound";
inline constexpr std::string_view kAiTask = "ai";

struct SoundAndAiOptions {
  stubs::SoundConfig sound;
  stubs::AiConfig ai;
  OutputFile* wav = nullptr;  // the whole run's mix, finished by close(); the caller publishes it
};

class SoundAndAi {
 public:
  // Builds the tasks for `world`'s frame time and container, and registers
  // their jobs with `scheduler`, which must not outlive this.  Throws
  // std::invalid_argument for task options out of their bounds.
  SoundAndAi(const physics::PhysicsWorld& world, SoundAndAiOptions options,
             FrameScheduler& scheduler);
  ~SoundAndAi();
  SoundAndAi(const SoundAndAi&) = delete;
  SoundAndAi& operator=(const SoundAndAi&) = delete;

  // Finishes the WAV file, if any.
  void close();

  std::uint64_t soundChecksum() const { return sound_checksum_; }
  std::uint64_t aiChecksum() const { return ai_.checksum(); }
  // The tasks' own work counters.
  const stubs::SoundWork& soundWork() const { return sound_.work(); }
  const stubs::AiWork& aiWork() const { return ai_.work(); }

 private:
  void snapshot();
  void runSound();

  const physics::PhysicsWorld& world_;
  stubs::SoundMixer sound_;
  stubs::AgentCrowd ai_;
  std::unique_ptr<stubs::WavWriter> wav_;
  std::vector<stubs::ImpactEvent> impacts_;
  std::vector<stubs::Obstacle> obstacles_;
  std::uint64_t sound_checksum_;
};

}  // namespace overlap::engine
