#include "physics/timed_world.h"

#include <algorithm>
#include <chrono>
#include <utility>

#include "gpu/base/interrupt.h"
#include "gpu/base/stopwatch.h"
#include "physics/broadphase/ccd_query_broadphase.h"

namespace overlap::physics {
namespace {

// The nearest body a fast body's swept sphere meets while closing on it:
// Bullet's CCD sweep (not the body itself, only what the collision filters
// and the dispatcher let it collide with and respond to, no hit it moves
// away from or grazes within the allowed penetration), with one change: a
// hit counts only when the body closes on what it hit by their relative
// motion over the substep, not by its own motion alone.
class ClosingSweep final : public btCollisionWorld::ClosestConvexResultCallback {
 public:
  ClosingSweep(const btRigidBody& body, const btVector3& to, btDispatcher& dispatcher,
               btScalar allowed_penetration, btScalar dt)
      : ClosestConvexResultCallback(body.getWorldTransform().getOrigin(), to),
        body_(body),
        dispatcher_(dispatcher),
        allowed_penetration_(allowed_penetration),
        dt_(dt) {
    m_collisionFilterGroup = body.getBroadphaseProxy()->m_collisionFilterGroup;
    m_collisionFilterMask = body.getBroadphaseProxy()->m_collisionFilterMask;
  }

  bool needsCollision(btBroadphaseProxy* proxy) const override {
    const auto* other = static_cast<const btCollisionObject*>(proxy->m_clientObject);
    if (other == &body_) return false;
    return ClosestConvexResultCallback::needsCollision(proxy) &&
           dispatcher_.needsCollision(&body_, other) && dispatcher_.needsResponse(&body_, other);
  }

  btScalar addSingleResult(btCollisionWorld::LocalConvexResult& hit,
                           bool normal_in_world) override {
    if (!hit.m_hitCollisionObject->hasContactResponse()) return 1;
    btVector3 closing = m_convexToWorld - m_convexFromWorld;
    if (const btRigidBody* other = btRigidBody::upcast(hit.m_hitCollisionObject)) {
      closing -= other->getLinearVelocity() * dt_;  // a wall's is zero
    }
    if (hit.m_hitNormalLocal.dot(closing) >= -allowed_penetration_) return 1;
    return ClosestConvexResultCallback::addSingleResult(hit, normal_in_world);
  }

 private:
  const btRigidBody& body_;
  btDispatcher& dispatcher_;
  btScalar allowed_penetration_;
  btScalar dt_;
};

}  // namespace

void applySolverSettings(btContactSolverInfo& info, SolverMode mode) {
  const SolverSettings solver = solverSettings(mode);
  info.m_numIterations = solver.iterations;
  info.m_warmstartingFactor = static_cast<btScalar>(solver.warmstarting_factor);
  info.m_splitImpulse = solver.split_impulse ? 1 : 0;
}

TimedDynamicsWorld::TimedDynamicsWorld(btDispatcher* dispatcher, btBroadphaseInterface* broadphase,
                                       btConstraintSolver* solver, btCollisionConfiguration* config,
                                       TimedWorldSetup setup)
    : btDiscreteDynamicsWorld(dispatcher, broadphase, solver, config), setup_(std::move(setup)) {}

TimedDynamicsWorld::~TimedDynamicsWorld() {
  releasePredictiveContacts();
}

void TimedDynamicsWorld::removeBody(btRigidBody& body) {
  const auto names = [&body](const btPersistentManifold& manifold) {
    return manifold.getBody0() == &body || manifold.getBody1() == &body;
  };
  std::vector<const btCollisionObject*> touched;
  for (int m = 0; m < m_dispatcher1->getNumManifolds(); ++m) {
    const btPersistentManifold& manifold = *m_dispatcher1->getManifoldByIndexInternal(m);
    if (!names(manifold) || manifold.getNumContacts() == 0) continue;
    touched.push_back(manifold.getBody0() == &body ? manifold.getBody1() : manifold.getBody0());
  }
  for (int i = 0; i < m_collisionObjects.size() && !touched.empty(); ++i) {
    btCollisionObject& object = *m_collisionObjects[i];
    if (std::find(touched.begin(), touched.end(), &object) != touched.end() &&
        !object.isStaticOrKinematicObject()) {
      object.activate(true);
    }
  }
  for (int m = m_predictiveManifolds.size() - 1; m >= 0; --m) {
    btPersistentManifold* manifold = m_predictiveManifolds[m];
    if (!names(*manifold)) continue;
    m_dispatcher1->releaseManifold(manifold);
    m_predictiveManifolds.removeAtIndex(m);
  }
  for (int c = getNumConstraints() - 1; c >= 0; --c) {
    btTypedConstraint* constraint = getConstraint(c);
    if (&constraint->getRigidBodyA() == &body || &constraint->getRigidBodyB() == &body) {
      removeConstraint(constraint);
    }
  }
  removeRigidBody(&body);
  body.setIslandTag(-1);
  body.setCompanionId(-1);
}

void TimedDynamicsWorld::beginFrame() {
  timings_ = {};
  substeps_.clear();
}

void TimedDynamicsWorld::stepReported(btScalar dt) {
  substeps_.push_back(SubstepReport{std::chrono::steady_clock::now(), {}, {}, {}, {}});
  reporting_ = true;
  try {
    // maxSubSteps = 0: exactly one step of dt, no accumulator rounding.
    stepSimulation(dt, 0);
  } catch (...) {
    reporting_ = false;
    throw;
  }
  reporting_ = false;
  substeps_.back().end = std::chrono::steady_clock::now();
}

template <typename Phase>
void TimedDynamicsWorld::timePhase(double& column, Phase&& phase) {
  const HostStopwatch watch;
  const double queries_before = ccdQueryMs();
  phase();
  const double queries = ccdQueryMs() - queries_before;
  timings_.ccd_query_ms += queries;
  column += watch.ms() - queries;
}

// The substep, phase by phase: Bullet's btDiscreteDynamicsWorld step with
// its collision detection (btCollisionWorld::performDiscreteCollisionDetection)
// written out, so the order is read here and each phase timed on its own.
void TimedDynamicsWorld::internalSingleStepSimulation(btScalar dt) {
  if (m_internalPreTickCallback != nullptr) (*m_internalPreTickCallback)(this, dt);
  // 1. predict
  timePhase(timings_.integrate_ms, [&] { predictUnconstraintMotion(dt); });
  btDispatcherInfo& dispatch = getDispatchInfo();
  dispatch.m_timeStep = dt;
  dispatch.m_stepCount = 0;
  dispatch.m_debugDraw = getDebugDrawer();
  // 2. CCD's predictive contacts
  timePhase(timings_.narrowphase_ms, [&] { createPredictiveContacts(dt); });
  // 3. update
  timePhase(timings_.update_ms, [&] {
    updateAabbs();
    if (setup_.after_aabb_update) setup_.after_aabb_update();
  });
  // 4. search
  searchPairs();
  // 5. narrowphase
  timePhase(timings_.narrowphase_ms, [&] {
    m_dispatcher1->dispatchAllCollisionPairs(m_broadphasePairCache->getOverlappingPairCache(),
                                             dispatch, m_dispatcher1);
  });
  if (SubstepReport* substep = reported())
    substep->narrowphase_end = std::chrono::steady_clock::now();
  if (setup_.after_narrowphase) setup_.after_narrowphase();
  // 6. solver
  timePhase(timings_.solver_ms, [&] {
    calculateSimulationIslands();
    getSolverInfo().m_timeStep = dt;
    solveConstraints(getSolverInfo());
  });
  // 7. integrate, with CCD's motion clamp
  timePhase(timings_.integrate_ms, [&] { integrateTransforms(dt); });
  // 8. bookkeeping
  updateActions(dt);
  updateActivationState(dt);
  if (m_internalTickCallback != nullptr) (*m_internalTickCallback)(this, dt);
}

void TimedDynamicsWorld::searchPairs() {
  SubstepReport* substep = reported();
  if (substep != nullptr) substep->broadphase_start = std::chrono::steady_clock::now();
  const HostStopwatch watch;
  m_broadphasePairCache->calculateOverlappingPairs(m_dispatcher1);
  timings_.broadphase_ms += watch.ms();
  // A finder cuts its search short for a signal (cpubf on 300 000 boxes
  // searches for half a minute): the substep stops here, not at the frame's end.
  if (pendingInterrupt() != 0) stopIfInterrupted("a substep's pair search");
  if (substep != nullptr) substep->narrowphase_start = std::chrono::steady_clock::now();
}

void TimedDynamicsWorld::integrateTransforms(btScalar dt) {
  for (int i = 0; i < m_nonStaticRigidBodies.size(); ++i)
    integrateBody(*m_nonStaticRigidBodies[i], dt);
  // Bullet's speculative restitution pass is left out with the rest of its
  // integrateTransforms: it is off unless asked for, and nothing asks.
}

double TimedDynamicsWorld::ccdQueryMs() const {
  return setup_.ccd_queries != nullptr ? setup_.ccd_queries->queryMs() : 0;
}

void TimedDynamicsWorld::integrateBody(btRigidBody& body, btScalar dt) {
  body.setHitFraction(1);
  if (!body.isActive() || body.isStaticOrKinematicObject()) return;
  btTransform predicted;
  body.predictIntegratedTransform(dt, predicted);
  const btScalar motion2 = (predicted.getOrigin() - body.getWorldTransform().getOrigin()).length2();
  const btScalar threshold2 = body.getCcdSquareMotionThreshold();
  if (getDispatchInfo().m_useContinuous && threshold2 != 0 && threshold2 < motion2 &&
      body.getCollisionShape()->isConvex()) {
    ClosingSweep sweep(body, predicted.getOrigin(), *getDispatcher(),
                       getDispatchInfo().m_allowedCcdPenetration, dt);
    const btSphereShape sphere(body.getCcdSweptSphereRadius());
    const btTransform to(body.getWorldTransform().getBasis(), predicted.getOrigin());
    convexSweepTest(&sphere, body.getWorldTransform(), to, sweep);
    if (sweep.hasHit() && sweep.m_closestHitFraction < 1) {
      // Up to the hit; the contact there answers in the next substep.
      body.predictIntegratedTransform(dt * sweep.m_closestHitFraction, predicted);
      body.setHitFraction(0);
    }
  }
  body.proceedToTransform(predicted);
}

}  // namespace overlap::physics
