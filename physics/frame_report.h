// What a frame of the world reports: its phases' times, its substeps as the
// main thread lived them, and the frame's record (pairs, errors, energy, the
// step's choices).  TimedDynamicsWorld (physics/timed_world.h) fills the
// timings and the substeps; PhysicsWorld (physics/world.h) the rest.  Plain
// values, below both worlds: nothing here knows Bullet.
//
// Invariants: each timing is summed over the frame's substeps, in
// milliseconds; a report's substep_reports are in the order they ran, one per
// substep (substeps of them).
#pragma once

#include <chrono>
#include <vector>

namespace overlap::physics {

struct FrameTimings {
  double update_ms = 0;       // AABBs written into the broadphase
  double broadphase_ms = 0;   // pair search and pair-cache update, one call per substep
  double narrowphase_ms = 0;  // contact generation for the cached pairs
  double solver_ms = 0;       // constraint solver
  double integrate_ms = 0;    // motion prediction and integration
  double ccd_query_ms = 0;    // CCD's sweeps finding what they may hit (CcdQueryBroadphase)
  double total_ms = 0;        // the whole step
  // Of the pair search's time, what ran beside the narrowphase (the search
  // less the main thread's wait for it); 0 unless the search runs beside it.
  double search_hidden_ms = 0;
};

// One substep, as the main thread lived it.  With the search beside the
// narrowphase, the narrowphase starts right after the search's launch and
// the search ends (search_end) inside it; otherwise search_wait and
// search_end are narrowphase_start.
struct SubstepReport {
  std::chrono::steady_clock::time_point start;
  std::chrono::steady_clock::time_point broadphase_start;   // the pair search called
  std::chrono::steady_clock::time_point narrowphase_start;  // the first contacts computed
  std::chrono::steady_clock::time_point search_wait;        // the main thread waits for the search
  std::chrono::steady_clock::time_point search_end;         // the search's pairs are in the cache
  std::chrono::steady_clock::time_point narrowphase_end;
  std::chrono::steady_clock::time_point end;
  bool search_beside = false;  // the search ran beside the narrowphase
};

struct FrameReport {
  int frame = 0;
  FrameTimings timings;
  std::vector<SubstepReport> substep_reports;  // one per substep, in order
  int pairs = 0;                               // overlapping pairs in the cache after the frame
  int escaped = 0;                             // boxes whose centre is beyond a wall's outer face
  int sunk = 0;                                // boxes whose centre is outside the interior
  double max_penetration = 0;                  // deepest contact overlap / that box's edge
  int removed_from_simulation = 0;             // boxes taken out: non-finite, huge or far away
  double kinetic_energy = 0;                   // J, linear and rotational, boxes in the simulation
  double potential_energy = 0;                 // J, -sum m (g . x) for the gravity of this frame
  int substeps = 0;                            // K this frame used
  int ccd_bodies = 0;                          // boxes with CCD this frame
  int sleeping = 0;                            // boxes asleep after the frame
  double fastest_speed = 0;  // m/s, the fastest box at the frame's start (K's input)
};

}  // namespace overlap::physics
