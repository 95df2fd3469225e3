// The game loop: one session of the game, the world with its frame scheduler
// and its sound and AI tasks, stepped frame by frame.  This is the one place
// a frame is stepped: `overlap run`, `capture`, `latency` and `record` (and
// the benchmark's recordings, engine/streams/recorded_streams.h) each build a
// session and step it, adding only what they keep of each frame.
//
// A session's frame, frame after frame in runFrames():
//   1. a signal received since the last frame stops the loop here
//      (gpu/base/interrupt.h's Interrupted, "frame F of N");
//   2. `before(F)`, if given: what must happen before this frame's step
//      (`run --compare-sync` steps its --sync session here, so both see the
//      machine alike);
//   3. the scheduler's frame (engine/runtime/frame_scheduler.h): the tasks'
//      snapshot, the sound and AI beside the physics step, the join; drawn on
//      the session's timeline;
//   4. `after(F, frame)`: what the caller keeps of it (a frames.csv row, a
//      PNG, the boxes' AABBs, a progress line).
// Rules, each with its reason:
// - The session owns the world, the scheduler, the tasks and the timeline,
//   built in that order and released in the reverse: the tasks' jobs point
//   into the world and the scheduler, which outlive them.
// - Without tasks (GameSessionOptions::tasks unset) the frame is the physics
//   step alone, on the calling thread: the same step, state and pairs as
//   physics::PhysicsWorld::stepFrame(), with the scheduler's timings.
// - runFrames(N) numbers its frames 0 to N - 1, in its callbacks and its
//   stop message; a later call steps on from the world's state, numbering
//   from 0 again.
// - finish() closes the tasks (the WAV is whole after it); the checksums
//   are final then, and a frame after it is a std::logic_error.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>

#include "engine/runtime/frame_scheduler.h"
#include "engine/runtime/sound_and_ai.h"
#include "engine/runtime/timeline.h"
#include "physics/world.h"

namespace overlap::engine {

struct GameSessionOptions {
  bool sync = false;                       // the frame's jobs one after another
  std::optional<SoundAndAiOptions> tasks;  // unset: physics only
};

class GameSession {
 public:
  using BeforeFrame = std::function<void(int frame)>;
  using AfterFrame = std::function<void(int frame, const ScheduledFrame& scheduled)>;

  // Takes `world` (built, its boxes placed) and registers the tasks' jobs.
  // Throws std::invalid_argument for task options out of their bounds.
  GameSession(std::unique_ptr<physics::PhysicsWorld> world, const GameSessionOptions& options);
  ~GameSession();
  GameSession(const GameSession&) = delete;
  GameSession& operator=(const GameSession&) = delete;

  // Steps `frames` frames, as the header says; `after` and `before` may be empty.
  void runFrames(int frames, const AfterFrame& after, const BeforeFrame& before = {});
  // One frame alone, step 3 of the header (no signal check, no callbacks):
  // for a session stepped in lockstep from another's `before` (run
  // --compare-sync's --sync session).
  ScheduledFrame step();

  // Closes the tasks: finishes the WAV, if any.  Idempotent.
  void finish();

  physics::PhysicsWorld& world() { return *world_; }
  const physics::PhysicsWorld& world() const { return *world_; }
  const Timeline& timeline() const { return timeline_; }
  bool hasTasks() const { return tasks_ != nullptr; }
  // The sound's checksum (gpu/base/checksum.h's empty FNV-1a without tasks)
  // and the AI's (0 without tasks).
  std::uint64_t soundChecksum() const;
  std::uint64_t aiChecksum() const;

 private:
  std::unique_ptr<physics::PhysicsWorld> world_;
  Timeline timeline_;
  FrameScheduler scheduler_;
  std::unique_ptr<SoundAndAi> tasks_;
  bool finished_ = false;
};

}  // namespace overlap::engine
