// SearchTimes: one broadphase search as the thread that launched and joined
// it saw it (physics/pair_finder_broadphase.h records them, physics/world.h
// reports them per substep).  Free of Bullet, so the engine can read them.
#pragma once

#include <chrono>

namespace overlap::physics {

struct SearchTimes {
  std::chrono::steady_clock::time_point launched;  // the boxes handed to the finder
  std::chrono::steady_clock::time_point joined;    // the caller began to wait
  double start_delay_ms = 0;   // launch to the search's start (a CPU worker's pick-up)
  double search_ms = 0;        // the search by its own clock (GPU events, or the CPU's)
  double join_ms = 0;          // waiting for the search and applying its changes
  double cache_update_ms = 0;  // of join_ms: applying the changes to the pair cache
};

}  // namespace overlap::physics
