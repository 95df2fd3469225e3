#include "engine/runtime/game_session.h"

#include <stdexcept>
#include <string>
#include <utility>

#include "gpu/base/checksum.h"
#include "gpu/base/interrupt.h"

namespace overlap::engine {

GameSession::GameSession(std::unique_ptr<physics::PhysicsWorld> world,
                         const GameSessionOptions& options)
    : world_(std::move(world)), scheduler_(*world_, {options.sync}, timeline_) {
  if (options.tasks) tasks_ = std::make_unique<SoundAndAi>(*world_, *options.tasks, scheduler_);
}

GameSession::~GameSession() = default;

ScheduledFrame GameSession::step() {
  if (finished_) throw std::logic_error("a game session stepped after finish()");
  return scheduler_.runFrame();
}

void GameSession::runFrames(int frames, const AfterFrame& after, const BeforeFrame& before) {
  for (int frame = 0; frame < frames; ++frame) {
    stopIfInterrupted("frame " + std::to_string(frame) + " of " + std::to_string(frames));
    if (before) before(frame);
    const ScheduledFrame scheduled = step();
    if (after) after(frame, scheduled);
  }
}

void GameSession::finish() {
  if (tasks_ && !finished_) tasks_->close();
  finished_ = true;
}

std::uint64_t GameSession::soundChecksum() const {
  return tasks_ ? tasks_->soundChecksum() : kFnv1aOffsetBasis;
}

std::uint64_t GameSession::aiChecksum() const {
  return tasks_ ? tasks_->aiChecksum() : 0;
}

}  // namespace overlap::engine
