// SearchTimes: one broadphase search as the thread that launched and joined
// it saw it (physics/pair_finder_broadphase.h records them, physics/world.h
// reports them per substep), as points on the steady clock; whoever writes
// them out converts them.  Free of Bullet, so the engine can read them.
#pragma once

#include <chrono>

namespace overlap::physics {

struct SearchTimes {
  std::chrono::steady_clock::time_point launched;  // the boxes handed to the finder
  std::chrono::steady_clock::time_point started;   // the search began: at once on a GPU
                                                   // stream, at a CPU worker's pick-up
  std::chrono::steady_clock::duration searched{};  // by the search's own clock (GPU events,
                                                   // or the searching thread's)
  std::chrono::steady_clock::time_point joined;    // the caller began to wait
  std::chrono::steady_clock::time_point answered;  // the finder's changes in hand: the
                                                   // pair-cache update begins
  std::chrono::steady_clock::time_point finished;  // the wait over, the pair cache updated
};

}  // namespace overlap::physics
