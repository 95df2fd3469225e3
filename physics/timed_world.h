// The btDiscreteDynamicsWorld PhysicsWorld steps: Bullet's own, with each
// stage of a substep timed from inside, and one repair to its CCD.
//
// Timing: update, broadphase, narrowphase, solver, integration and CCD's
// sweep queries add into `timings` over the frame's substeps (a sweep's
// query is taken out of the stage that asked for it); each substep started by the caller
// (an entry pushed on `substeps`) gets its narrowphase's start and end and,
// for a broadphase that searches off the main thread (PairFinderBroadphase),
// that search's times.  A step from outside stepFrame() (no entry pushed)
// is timed but not reported per substep.
//
// CCD: Bullet's motion clamp sweeps a fast body's sphere along the body's
// own motion and stops it at the first body it meets while moving towards
// it, as if that body stood still.  Two overlapping CCD boxes falling side
// by side then stop each other every substep while gravity keeps adding
// speed: in scene 3 at 3500 boxes (K = 8, --ccd auto) a pair froze in mid-air
// at frame 9 and reached 3462 m/s by frame 240, and at 1000 boxes (K = 2)
// released pairs flew out through the walls (39 boxes).  Here a hit stops
// the body only when the two close by their relative motion over the
// substep (a wall's velocity is zero, so walls are as before).  Sweeping
// against the walls alone (Bullet's USE_STATIC_ONLY variant, compiled out of
// Debian's build) also ends the freeze but lets small boxes through large
// moving ones: scene 4's deepest penetration at 3500 boxes was 6.17 edges
// with it and 2.37 with the relative test (1000 boxes: 2.61, 2.71, 2.34
// against 2.36, 1.97, 2.37 at seeds 42, 7, 123).
//
// Bullet is not thread-safe here: one world, one thread.
#pragma once

#include <btBulletDynamicsCommon.h>

#include <functional>
#include <vector>

#include "physics/step_policy.h"
#include "physics/world.h"

namespace overlap::physics {

class CcdQueryBroadphase;
class PairFinderBroadphase;

class TimedDynamicsWorld final : public btDiscreteDynamicsWorld {
 public:
  using btDiscreteDynamicsWorld::btDiscreteDynamicsWorld;
  // Bullet hands the last substep's CCD contacts (its predictive manifolds)
  // back only when the next step starts; a world that is not stepped again
  // must do it, or those the dispatcher's pool could not hold leak.
  ~TimedDynamicsWorld() override;

  FrameTimings timings;
  std::vector<SubstepReport> substeps;                // this frame's, the last one running
  PairFinderBroadphase* background_search = nullptr;  // set when the broadphase searches off-thread
  CcdQueryBroadphase* ccd_queries = nullptr;          // set when CCD's sweeps are to be timed apart
  std::function<void()> after_aabb_update;
  std::function<void()> after_narrowphase;

  void updateAabbs() override;
  void computeOverlappingPairs() override;
  // update + broadphase + narrowphase; the narrowphase is what remains.
  void performDiscreteCollisionDetection() override;
  void createPredictiveContacts(btScalar dt) override;
  void calculateSimulationIslands() override;
  void solveConstraints(btContactSolverInfo& info) override;
  void predictUnconstraintMotion(btScalar dt) override;
  // Bullet's integrateTransforms with the CCD clamp on relative motion.
  void integrateTransforms(btScalar dt) override;

 private:
  // Moves `body` by its velocities over dt, stopped where its swept sphere
  // first meets a body it closes on, when its motion exceeds its CCD
  // threshold.
  void integrateBody(btRigidBody& body, btScalar dt);
  double ccdQueryMs() const;
};

// Sets Bullet's contact solver up as solverSettings(mode) says: the one
// place those numbers reach Bullet (PhysicsWorld and the tests share it).
void applySolverSettings(btContactSolverInfo& info, SolverMode mode);

}  // namespace overlap::physics
