// The btDiscreteDynamicsWorld PhysicsWorld steps: Bullet's own, with its
// substep written out phase by phase, each phase timed, one repair to its
// CCD, and a body removal safe at any point of a substep (removeBody).
//
// A substep, in order (internalSingleStepSimulation, Bullet's order kept
// call for call), and the column of `timings` each phase adds to:
//   1. predict      gravity and damping into the velocities, each body's
//                   predicted transform                          integrate_ms
//   2. CCD          predictive contacts for fast bodies          narrowphase_ms
//   3. update       AABBs into the broadphase; after_aabb_update  update_ms
//   4. search       the pair search and the pair-cache update,
//                   one call (calculateOverlappingPairs)          broadphase_ms
//   5. narrowphase  contacts for the cached pairs; then
//                   after_narrowphase (untimed)                  narrowphase_ms
//   6. solver       simulation islands, the constraint solver    solver_ms
//   7. integrate    velocities into transforms, with CCD's
//                   motion clamp (integrateBody)                 integrate_ms
//   8. bookkeeping  Bullet's actions and sleep                   total only
// CCD's sweep queries (in 2 and 7) are taken out of their phase into
// ccd_query_ms (when the setup names the query tree).  A substep run by
// stepReported() is also reported: when it started, when its search and its
// narrowphase ran, when it ended.  A step from elsewhere (stepSimulation) is
// timed but not reported per substep.
//
// The search is one call, before the narrowphase, because the narrowphase
// needs this substep's pairs; the frame's other work (the engine's tasks)
// runs beside the whole step instead (docs/DESIGN.md).
//
// CCD: Bullet's motion clamp stops a fast body at the first body its swept
// sphere meets while moving towards it, as if that body stood still, so two
// overlapping CCD boxes falling side by side stop each other every substep
// while gravity keeps adding speed (they freeze in mid-air, and fly through
// the walls once released).  Here a hit stops the body only when the two
// close by their relative motion over the substep (a wall's velocity is zero,
// so walls are as before).  Sweeping against the walls alone (Bullet's
// USE_STATIC_ONLY variant, compiled out of Debian's build) also ends the
// freeze but lets small boxes through large moving ones.  Measured in
// docs/REPORT.md, section 3.2.
//
// Bullet is not thread-safe here: one world, one thread.
#pragma once

#include <btBulletDynamicsCommon.h>

#include <functional>
#include <utility>
#include <vector>

#include "physics/frame_report.h"
#include "physics/step_policy.h"

namespace overlap::physics {

class CcdQueryBroadphase;

// What TimedDynamicsWorld needs from its owner, given when it is built.
struct TimedWorldSetup {
  const CcdQueryBroadphase* ccd_queries = nullptr;  // CCD's sweeps, timed apart into ccd_query_ms
  std::function<void()> after_aabb_update;          // in phase 3, before the search reads them
  std::function<void()> after_narrowphase;          // after phase 5, before the solver
};

class TimedDynamicsWorld final : public btDiscreteDynamicsWorld {
 public:
  TimedDynamicsWorld(btDispatcher* dispatcher, btBroadphaseInterface* broadphase,
                     btConstraintSolver* solver, btCollisionConfiguration* config,
                     TimedWorldSetup setup = {});
  // Bullet hands the last substep's CCD contacts (its predictive manifolds)
  // back only when the next step starts; a world that is not stepped again
  // must do it, or those the dispatcher's pool could not hold leak.
  ~TimedDynamicsWorld() override;

  // Starts a frame's record: its timings zeroed, no substep reported.
  void beginFrame();
  // One substep of dt (exactly one: no accumulator), reported.
  void stepReported(btScalar dt);
  // The frame's timings so far, each phase summed over its substeps.
  const FrameTimings& timings() const { return timings_; }
  // The frame's reported substeps, in order, moved out.
  std::vector<SubstepReport> takeSubsteps() { return std::exchange(substeps_, {}); }

  // Takes `body` out of the world at any point of a substep, leaving nothing
  // in Bullet that still names it: its pairs and their contacts
  // (removeRigidBody, through the pair cache and the dispatcher), its CCD
  // contacts of this substep (predictive manifolds, which Bullet keeps apart
  // and the solver's deterministic manifold sort would read through the
  // body's removed broadphase proxy), the constraints that name it, and its
  // island and solver marks.  The bodies it touched are woken: what rested
  // on it must not sleep in mid-air.
  void removeBody(btRigidBody& body);

 protected:
  // One substep: the phases above, in order.
  void internalSingleStepSimulation(btScalar dt) override;
  // Phase 7: Bullet's integrateTransforms with the CCD clamp on relative motion.
  void integrateTransforms(btScalar dt) override;

 private:
  // Runs `phase`, adding its time to `column`; CCD's sweep queries made
  // inside go to ccd_query_ms instead.
  template <typename Phase>
  void timePhase(double& column, Phase&& phase);
  // Phase 4; stamps the reported substep's search and narrowphase start.
  void searchPairs();
  // The substep being reported, or none.
  SubstepReport* reported() { return reporting_ ? &substeps_.back() : nullptr; }
  // Moves `body` by its velocities over dt, stopped where its swept sphere
  // first meets a body it closes on, when its motion exceeds its CCD
  // threshold.
  void integrateBody(btRigidBody& body, btScalar dt);
  double ccdQueryMs() const;

  TimedWorldSetup setup_;
  FrameTimings timings_;
  std::vector<SubstepReport> substeps_;  // this frame's, the last one running
  bool reporting_ = false;               // inside stepReported()
};

// Sets Bullet's contact solver up as solverSettings(mode) says: the one
// place those numbers reach Bullet (PhysicsWorld and the tests share it).
void applySolverSettings(btContactSolverInfo& info, SolverMode mode);

}  // namespace overlap::physics
