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
//   5. narrowphase  contacts for the cached pairs               narrowphase_ms
//   6. solver       simulation islands (after_narrowphase beside
//                   them), the constraint solver in one group    solver_ms
//   7. integrate    velocities into transforms, with CCD's
//                   motion clamp (integrateBody)                 integrate_ms
//   8. bookkeeping  Bullet's actions and sleep                   total only
// CCD's sweep queries (in 2 and 7) are taken out of their phase into
// ccd_query_ms (when the setup names the query tree).  A substep run by
// stepReported() is also reported: when it started, when its search and its
// narrowphase ran, when it ended.  A step from elsewhere (stepSimulation) is
// timed but not reported per substep.
//
// The search is one call before the narrowphase, which needs this substep's
// pairs, or, with TimedWorldSetup::search_beside, it runs beside the
// narrowphase of the pairs already cached (searchBesideNarrowphase); the
// frame's other work (the engine's tasks) runs beside the whole step
// (docs/DESIGN.md).
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
// Threads: the world is called from one thread.  With a task system in the
// setup, the per-body parts of phases 1, 2, 3, 7 and 8 run on it, each body's
// piece writing only that body (or its own slot of a vector); what touches
// shared state (the broadphase's setAabb, the predictive manifolds) runs
// after, in body order, as Bullet runs it.  Phase 7 finds every body's move
// before it applies any, so a sweep never sees a body moved this substep
// whatever the thread count.  The narrowphase runs on it through the
// world's ParallelDispatcher (physics/parallel_dispatcher.h).
#pragma once

#include <btBulletDynamicsCommon.h>

#include <atomic>
#include <functional>
#include <memory>
#include <utility>
#include <vector>

#include "gpu/task_system.h"
#include "physics/frame_report.h"
#include "physics/island_group.h"
#include "physics/step_policy.h"

namespace overlap::physics {

class CcdQueryBroadphase;
class PairFinderBroadphase;
class ParallelDispatcher;

// What TimedDynamicsWorld needs from its owner, given when it is built.
struct TimedWorldSetup {
  // CCD's sweeps, timed apart into ccd_query_ms; its tree is refreshed
  // beside the solver when a body has CCD on.
  CcdQueryBroadphase* ccd_queries = nullptr;
  TaskSystem* tasks = nullptr;  // the step's parallel parts; null: none
  // Our broadphase, when its search is to run beside the narrowphase (with a
  // ParallelDispatcher that dispatches in parallel); null: search, then narrowphase.
  PairFinderBroadphase* search_beside = nullptr;
  std::function<void()> after_aabb_update;  // in phase 3, before the search reads them
  // After phase 5, before the solver's first row: with a task system, on it
  // beside the islands (which write only the bodies' island, activation and
  // companion marks), so it may read the bodies' poses and speeds and the
  // manifolds, and write nothing of Bullet's.
  std::function<void()> after_narrowphase;
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
  // Phase 1, per body on the task system: Bullet's damping and predicted transform.
  void predictUnconstraintMotion(btScalar dt) override;
  // Phase 2: Bullet's predictive contacts; the sweeps on the task system, the
  // manifolds made after them in body order, as Bullet makes them.
  void createPredictiveContacts(btScalar dt) override;
  // Phase 3: Bullet's AABBs computed on the task system, handed to the
  // broadphase in object order, as Bullet hands them.
  void updateAabbs() override;
  // Phase 7: Bullet's integrateTransforms with the CCD clamp on relative
  // motion: every body's move found on the task system from the substep's
  // transforms, then applied, so no sweep reads a body moved this substep.
  void integrateTransforms(btScalar dt) override;

 private:
  // Runs `phase`, adding its time to `column`; CCD's sweep queries made
  // inside go to ccd_query_ms instead.
  template <typename Phase>
  void timePhase(double& column, Phase&& phase);
  // Phases 4 and 5, one after the other or the search beside the
  // narrowphase; stamps the reported substep's times.
  void searchAndNarrowphase(btDispatcherInfo& dispatch);
  // Phase 4 alone; stamps the reported substep's search and narrowphase start.
  void searchPairs();
  void searchBesideNarrowphase(btDispatcherInfo& dispatch);
  void stopIfSearchInterrupted() const;
  // The substep being reported, or none.
  SubstepReport* reported() { return reporting_ ? &substeps_.back() : nullptr; }
  // Where `body` moves by its velocities over dt, stopped where its swept
  // sphere first meets a body it closes on, when its motion exceeds its CCD
  // threshold.
  btTransform integratedTransform(btRigidBody& body, btScalar dt) const;
  // body(i) for i in [0, count), on the task system when there is one
  // (pieces of `grain`), each i writing only its own body's state.
  template <typename Body>
  void forEachIndex(int count, std::size_t grain, const Body& body);
  double ccdQueryMs() const;
  // Phase 6, with the query tree's refresh for phase 7's sweeps and the
  // setup's after_narrowphase beside it.
  void solveBesideQueryRefresh();
  // Returns when the after_narrowphase job has ended (at once when none runs).
  void awaitNarrowphaseRecord();
  // Bullet's islands solved in one solveGroup call (physics/island_group.h),
  // or Bullet's own island path where that does not model the world.
  void solveIslands();
  // Whether a body sweeps this substep when it moves fast: one with a CCD threshold.
  bool anyCcdBody() const;

  // Per body of the substep's phase: what its parallel part found.
  struct PredictiveHit {
    const btCollisionObject* other = nullptr;  // null: none
    btVector3 normal, to;
    btScalar fraction = 1;
  };

  TimedWorldSetup setup_;
  std::vector<PredictiveHit> predictive_hits_;
  std::vector<btTransform> moves_;
  struct NewAabb {
    btVector3 min, max;
  };
  std::vector<NewAabb> new_aabbs_;
  std::atomic<double> piece_ms_{0};           // the parallel pieces' time, on all threads
  ParallelDispatcher* parallel_dispatcher_;   // the world's dispatcher when it is one
  std::unique_ptr<TaskGroup> search_group_;   // the search job beside the narrowphase
  std::unique_ptr<TaskGroup> refresh_group_;  // the query tree's refresh beside the solver
  std::unique_ptr<TaskGroup> record_group_;   // after_narrowphase beside the islands
  bool record_pending_ = false;               // its job runs
  IslandGroup island_group_;                  // the solver's one group, kept for its capacity
  FrameTimings timings_;
  std::vector<SubstepReport> substeps_;  // this frame's, the last one running
  bool reporting_ = false;               // inside stepReported()
};

// Sets Bullet's contact solver up as solverSettings(mode) says: the one
// place those numbers reach Bullet (PhysicsWorld and the tests share it).
void applySolverSettings(btContactSolverInfo& info, SolverMode mode);

}  // namespace overlap::physics
