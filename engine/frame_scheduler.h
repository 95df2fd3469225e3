// The asynchronous frame: the game loop this project is named for.
//
// Each frame, on the main thread, the jobs below run in this order; each
// names what it depends on.  Bullet is only ever called from the main thread.
//   1. snapshot    main      last frame's box positions and new contacts,
//                            copied into plain arrays   (depends on: last frame)
//   2. update      main      AABBs into the broadphase  (depends on: 1)
//   3. launch      GPU or    the broadphase search      (depends on: 2)
//                  worker
//   4. sound, AI   TBB       the stub game systems      (depends on: 1 only)
//   5. join        main      wait for 3 and 4           (depends on: 3, 4)
//   6. apply       main      the search's pair changes into Bullet's cache
//   7. narrowphase, solver, integrate   main            (depends on: 6)
// Jobs 2-7 happen inside Bullet's step (PhysicsWorld::stepFrame), which
// calls back into the scheduler between 3 and 5.  With `sync`, the same work
// runs one job after another: sound, AI, then the broadphase.  Both orders
// give the same pairs and the same state: the tasks only read the snapshot.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <vector>

#include "audio_ai_stubs/ai.h"
#include "audio_ai_stubs/sound.h"
#include "audio_ai_stubs/wav_writer.h"
#include "engine/timeline.h"
#include "physics/world.h"

namespace overlap::engine {

struct SchedulerOptions {
  bool sync = false;  // run the tasks before the broadphase instead of beside it
  bool tasks = true;  // false: physics only (the paper's measurements)
  stubs::SoundConfig sound;
  stubs::AiConfig ai;
  std::optional<std::filesystem::path> wav;  // the whole run's mix
};

struct ScheduledFrame {
  physics::FrameReport physics;
  double sound_ms = 0;
  double ai_ms = 0;
  double search_ms = 0;           // the search itself: GPU events or its worker's clock
  double overlap_efficiency = 0;  // share of the search that ran while a CPU task ran
};

class FrameScheduler {
 public:
  FrameScheduler(physics::PhysicsWorld& world, const SchedulerOptions& options, Timeline& timeline);
  ~FrameScheduler();

  ScheduledFrame runFrame();
  // Finishes the WAV file, if any.
  void close();

  std::uint64_t soundChecksum() const { return sound_checksum_; }
  std::uint64_t aiChecksum() const;
  // The tasks' own work counters; null when the tasks are off.
  const stubs::SoundWork* soundWork() const { return sound_ ? &sound_->work() : nullptr; }
  const stubs::AiWork* aiWork() const { return ai_ ? &ai_->work() : nullptr; }

 private:
  void snapshot();
  void runSound();
  void runAi();
  void runTasks();

  physics::PhysicsWorld& world_;
  SchedulerOptions options_;
  Timeline& timeline_;
  std::unique_ptr<stubs::SoundMixer> sound_;
  std::unique_ptr<stubs::AgentCrowd> ai_;
  std::unique_ptr<stubs::WavWriter> wav_;
  std::vector<stubs::ImpactEvent> impacts_;
  std::vector<stubs::Obstacle> obstacles_;
  std::uint64_t sound_checksum_;
  int frame_ = 0;
  // This frame's task spans (start, end) in timeline microseconds; each is
  // written only by its own task.
  std::pair<double, double> sound_span_{};
  std::pair<double, double> ai_span_{};
};

}  // namespace overlap::engine
