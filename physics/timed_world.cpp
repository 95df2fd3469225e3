#include "physics/timed_world.h"

#include <algorithm>
#include <chrono>
#include <utility>

#include "gpu/base/interrupt.h"
#include "gpu/base/stopwatch.h"
#include "physics/broadphase/ccd_query_broadphase.h"
#include "physics/broadphase/pair_finder_broadphase.h"
#include "physics/parallel_dispatcher.h"

namespace overlap::physics {
namespace {

// Bodies a piece of the per-body phases: a body's damping or AABB is a few
// hundred nanoseconds; a CCD sweep is microseconds.
constexpr std::size_t kBodiesPerPiece = 256;
constexpr std::size_t kSweepsPerPiece = 64;

// The nearest body a fast body's swept sphere meets while closing on it:
// Bullet's CCD sweep (not the body itself, only what the collision filters,
// the pair cache's overlap filter and the dispatcher let it collide with and
// respond to, no hit it moves away from or grazes within the allowed
// penetration).  With kOwn it is Bullet's own (btDiscreteDynamicsWorld's
// predictive contacts: closing by the body's motion alone); with kRelative a
// hit counts only when the two close by their relative motion over the
// substep (the motion clamp of integrateTransforms).
class CcdSweep final : public btCollisionWorld::ClosestConvexResultCallback {
 public:
  enum class Closing { kOwn, kRelative };

  CcdSweep(const btRigidBody& body, const btVector3& to, btOverlappingPairCache& pairs,
           btDispatcher& dispatcher, btScalar allowed_penetration, Closing closing, btScalar dt)
      : ClosestConvexResultCallback(body.getWorldTransform().getOrigin(), to),
        body_(body),
        pairs_(pairs),
        dispatcher_(dispatcher),
        allowed_penetration_(allowed_penetration),
        closing_(closing),
        dt_(dt) {
    m_collisionFilterGroup = body.getBroadphaseProxy()->m_collisionFilterGroup;
    m_collisionFilterMask = body.getBroadphaseProxy()->m_collisionFilterMask;
  }

  bool needsCollision(btBroadphaseProxy* proxy) const override {
    const auto* other = static_cast<const btCollisionObject*>(proxy->m_clientObject);
    if (other == &body_ || !ClosestConvexResultCallback::needsCollision(proxy)) return false;
    if (pairs_.getOverlapFilterCallback() != nullptr &&
        !pairs_.needsBroadphaseCollision(
            proxy, const_cast<btBroadphaseProxy*>(body_.getBroadphaseHandle()))) {
      return false;
    }
    return dispatcher_.needsCollision(&body_, other) && dispatcher_.needsResponse(&body_, other);
  }

  btScalar addSingleResult(btCollisionWorld::LocalConvexResult& hit,
                           bool normal_in_world) override {
    if (hit.m_hitCollisionObject == &body_ || !hit.m_hitCollisionObject->hasContactResponse()) {
      return 1;
    }
    btVector3 closing = m_convexToWorld - m_convexFromWorld;
    if (closing_ == Closing::kRelative) {
      if (const btRigidBody* other = btRigidBody::upcast(hit.m_hitCollisionObject)) {
        closing -= other->getLinearVelocity() * dt_;  // a wall's is zero
      }
    }
    if (hit.m_hitNormalLocal.dot(closing) >= -allowed_penetration_) return 1;
    return ClosestConvexResultCallback::addSingleResult(hit, normal_in_world);
  }

 private:
  const btRigidBody& body_;
  btOverlappingPairCache& pairs_;
  btDispatcher& dispatcher_;
  btScalar allowed_penetration_;
  Closing closing_;
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
    : btDiscreteDynamicsWorld(dispatcher, broadphase, solver, config),
      setup_(std::move(setup)),
      parallel_dispatcher_(dynamic_cast<ParallelDispatcher*>(dispatcher)) {
  if (setup_.search_beside != nullptr && setup_.tasks != nullptr) {
    search_group_ = setup_.tasks->makeGroup();
  }
  if (setup_.ccd_queries != nullptr && setup_.tasks != nullptr) {
    refresh_group_ = setup_.tasks->makeGroup();
  }
  if (setup_.after_narrowphase && setup_.tasks != nullptr) {
    record_group_ = setup_.tasks->makeGroup();
  }
}

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
  substeps_.push_back(SubstepReport{});
  substeps_.back().start = std::chrono::steady_clock::now();
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

// A phase whose queries ran on several threads at once gives them the share
// of its time that they took of its pieces' time on all threads.
template <typename Phase>
void TimedDynamicsWorld::timePhase(double& column, Phase&& phase) {
  const HostStopwatch watch;
  const double queries_before = ccdQueryMs();
  const double pieces_before = piece_ms_.load(std::memory_order_relaxed);
  phase();
  const double wall = watch.ms();
  double queries = ccdQueryMs() - queries_before;
  const double pieces = piece_ms_.load(std::memory_order_relaxed) - pieces_before;
  if (pieces > 0) queries = wall * std::min(1.0, queries / pieces);
  queries = std::min(queries, wall);
  timings_.ccd_query_ms += queries;
  column += wall - queries;
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
  // 4. search and 5. narrowphase
  searchAndNarrowphase(dispatch);
  if (setup_.after_narrowphase && record_group_ == nullptr) setup_.after_narrowphase();
  // 6. solver
  getSolverInfo().m_timeStep = dt;
  solveBesideQueryRefresh();
  // 7. integrate, with CCD's motion clamp
  timePhase(timings_.integrate_ms, [&] { integrateTransforms(dt); });
  // 8. bookkeeping
  updateActions(dt);
  updateActivationState(dt);
  if (m_internalTickCallback != nullptr) (*m_internalTickCallback)(this, dt);
}

void TimedDynamicsWorld::searchAndNarrowphase(btDispatcherInfo& dispatch) {
  if (search_group_ != nullptr && parallel_dispatcher_ != nullptr &&
      parallel_dispatcher_->dispatchesInParallel(dispatch)) {
    searchBesideNarrowphase(dispatch);
  } else {
    searchPairs();
    timePhase(timings_.narrowphase_ms, [&] {
      m_dispatcher1->dispatchAllCollisionPairs(m_broadphasePairCache->getOverlappingPairCache(),
                                               dispatch, m_dispatcher1);
    });
  }
  if (SubstepReport* substep = reported()) {
    substep->narrowphase_end = std::chrono::steady_clock::now();
  }
}

// A finder cuts its search short for a signal (cpubf on 300 000 boxes
// searches for half a minute): the substep stops here, not at the frame's end.
void TimedDynamicsWorld::stopIfSearchInterrupted() const {
  if (pendingInterrupt() != 0) stopIfInterrupted("a substep's pair search");
}

void TimedDynamicsWorld::searchPairs() {
  SubstepReport* substep = reported();
  if (substep != nullptr) substep->broadphase_start = std::chrono::steady_clock::now();
  const HostStopwatch watch;
  m_broadphasePairCache->calculateOverlappingPairs(m_dispatcher1);
  timings_.broadphase_ms += watch.ms();
  stopIfSearchInterrupted();
  if (substep != nullptr) {
    substep->narrowphase_start = substep->search_wait = substep->search_end =
        std::chrono::steady_clock::now();
  }
}

// The search launched, the cached pairs' contacts while it runs, then the
// wait, the cache update and the new pairs' contacts
// (physics/parallel_dispatcher.h says why the state is the serial order's).
void TimedDynamicsWorld::searchBesideNarrowphase(btDispatcherInfo& dispatch) {
  PairFinderBroadphase& search = *setup_.search_beside;
  btOverlappingPairCache* cache = m_broadphasePairCache->getOverlappingPairCache();
  SubstepReport* substep = reported();
  const auto now = [] { return std::chrono::steady_clock::now(); };
  if (substep != nullptr) {
    substep->search_beside = true;
    substep->broadphase_start = now();
  }
  const HostStopwatch launch_watch;
  search.beginSearch(*search_group_);
  const double launch_ms = launch_watch.ms();
  if (substep != nullptr) substep->narrowphase_start = now();
  try {
    timePhase(timings_.narrowphase_ms,
              [&] { parallel_dispatcher_->dispatchStayingPairs(cache, dispatch); });
  } catch (...) {
    search_group_->wait();  // the search job ends before the error leaves
    throw;
  }
  if (substep != nullptr) substep->search_wait = now();
  const HostStopwatch end_watch;
  search.endSearch(m_dispatcher1);
  timings_.broadphase_ms += launch_ms + end_watch.ms();
  const double search_ms = search.lastSearchStats().search_ms;
  timings_.search_hidden_ms += std::clamp(search_ms - search.lastSearchWaitMs(), 0.0, search_ms);
  if (substep != nullptr) substep->search_end = now();
  stopIfSearchInterrupted();
  timePhase(timings_.narrowphase_ms,
            [&] { parallel_dispatcher_->dispatchRemainingPairs(cache, dispatch); });
}

// The AABBs of phase 3 are the last the query tree takes before phase 7's
// sweeps, and the solver makes no query: the tree takes them now, on a
// thread beside the solver (Bullet's serial solver leaves the others idle),
// not at phase 7's first sweep.  With one thread the job runs at the wait,
// where that sweep would have run it; either way the tree takes the same
// AABBs in the same order, whatever the thread count.
void TimedDynamicsWorld::solveBesideQueryRefresh() {
  const bool refresh =
      refresh_group_ != nullptr && getDispatchInfo().m_useContinuous && anyCcdBody();
  if (refresh) refresh_group_->run([this] { setup_.ccd_queries->refreshForQueries(); });
  if (record_group_ != nullptr) {
    record_group_->run([this] { setup_.after_narrowphase(); });
    record_pending_ = true;
  }
  try {
    timePhase(timings_.solver_ms, [&] {
      calculateSimulationIslands();
      solveIslands();
    });
  } catch (...) {
    // The jobs end before the error leaves.
    if (refresh) refresh_group_->wait();
    awaitNarrowphaseRecord();
    throw;
  }
  if (refresh) {
    const HostStopwatch wait_watch;
    refresh_group_->wait();
    timings_.ccd_query_ms += wait_watch.ms();
  }
}

void TimedDynamicsWorld::awaitNarrowphaseRecord() {
  if (!record_pending_) return;
  record_pending_ = false;
  record_group_->wait();
}

void TimedDynamicsWorld::solveIslands() {
  if (!IslandGroup::models(*this)) {
    awaitNarrowphaseRecord();
    solveConstraints(getSolverInfo());
    return;
  }
  btContactSolverInfo& info = getSolverInfo();
  m_constraintSolver->prepareSolve(getNumCollisionObjects(), m_dispatcher1->getNumManifolds());
  island_group_.gather(*this);
  // The solver writes the velocities the record reads.
  awaitNarrowphaseRecord();
  m_constraintSolver->solveGroup(island_group_.bodies(), island_group_.bodyCount(),
                                 island_group_.manifolds(), island_group_.manifoldCount(), nullptr,
                                 0, info, m_debugDrawer, m_dispatcher1);
  m_constraintSolver->allSolved(info, m_debugDrawer);
}

bool TimedDynamicsWorld::anyCcdBody() const {
  for (int i = 0; i < m_nonStaticRigidBodies.size(); ++i) {
    if (m_nonStaticRigidBodies[i]->getCcdSquareMotionThreshold() != 0) return true;
  }
  return false;
}

template <typename Body>
void TimedDynamicsWorld::forEachIndex(int count, std::size_t grain, const Body& body) {
  const auto n = static_cast<std::size_t>(std::max(count, 0));
  if (setup_.tasks == nullptr) {
    for (std::size_t i = 0; i < n; ++i) body(static_cast<int>(i));
    return;
  }
  setup_.tasks->forEachPiece(n, grain, [&](std::size_t first, std::size_t end) {
    const HostStopwatch watch;
    for (std::size_t i = first; i < end; ++i) body(static_cast<int>(i));
    piece_ms_.fetch_add(watch.ms(), std::memory_order_relaxed);
  });
}

void TimedDynamicsWorld::predictUnconstraintMotion(btScalar dt) {
  forEachIndex(m_nonStaticRigidBodies.size(), kBodiesPerPiece, [&](int i) {
    btRigidBody& body = *m_nonStaticRigidBodies[i];
    if (body.isStaticOrKinematicObject()) return;
    body.applyDamping(dt);
    body.predictIntegratedTransform(dt, body.getInterpolationWorldTransform());
  });
}

void TimedDynamicsWorld::createPredictiveContacts(btScalar dt) {
  releasePredictiveContacts();
  const int count = m_nonStaticRigidBodies.size();
  predictive_hits_.assign(static_cast<std::size_t>(count), PredictiveHit{});
  // The sweeps read the substep's transforms and the query tree only.
  forEachIndex(count, kSweepsPerPiece, [&](int i) {
    btRigidBody& body = *m_nonStaticRigidBodies[i];
    body.setHitFraction(1);
    if (!body.isActive() || body.isStaticOrKinematicObject()) return;
    btTransform predicted;
    body.predictIntegratedTransform(dt, predicted);
    const btScalar motion2 =
        (predicted.getOrigin() - body.getWorldTransform().getOrigin()).length2();
    const btScalar threshold2 = body.getCcdSquareMotionThreshold();
    if (!getDispatchInfo().m_useContinuous || threshold2 == 0 || !(threshold2 < motion2) ||
        !body.getCollisionShape()->isConvex()) {
      return;
    }
    CcdSweep sweep(body, predicted.getOrigin(), *m_broadphasePairCache->getOverlappingPairCache(),
                   *m_dispatcher1, getDispatchInfo().m_allowedCcdPenetration,
                   CcdSweep::Closing::kOwn, dt);
    const btSphereShape sphere(body.getCcdSweptSphereRadius());
    btTransform to = predicted;
    to.setBasis(body.getWorldTransform().getBasis());
    convexSweepTest(&sphere, body.getWorldTransform(), to, sweep);
    if (sweep.hasHit() && sweep.m_closestHitFraction < 1) {
      predictive_hits_[static_cast<std::size_t>(i)] =
          PredictiveHit{sweep.m_hitCollisionObject, sweep.m_hitNormalWorld, predicted.getOrigin(),
                        sweep.m_closestHitFraction};
    }
  });
  // Bullet's manifolds and points, in body order.
  for (int i = 0; i < count; ++i) {
    const PredictiveHit& hit = predictive_hits_[static_cast<std::size_t>(i)];
    if (hit.other == nullptr) continue;
    btRigidBody& body = *m_nonStaticRigidBodies[i];
    const btVector3 from = body.getWorldTransform().getOrigin();
    const btVector3 moved = (hit.to - from) * hit.fraction;
    const btScalar distance = moved.dot(-hit.normal);
    btPersistentManifold* manifold = m_dispatcher1->getNewManifold(&body, hit.other);
    m_predictiveManifolds.push_back(manifold);
    const btVector3 world_b = from + moved;
    const btVector3 local_b = hit.other->getWorldTransform().inverse() * world_b;
    const btManifoldPoint point(btVector3(0, 0, 0), local_b, hit.normal, distance);
    btManifoldPoint& added = manifold->getContactPoint(manifold->addManifoldPoint(point, true));
    added.m_combinedRestitution = 0;
    added.m_combinedFriction = gCalculateCombinedFrictionCallback(&body, hit.other);
    added.m_positionWorldOnA = from;
    added.m_positionWorldOnB = world_b;
  }
}

void TimedDynamicsWorld::updateAabbs() {
  const int count = m_collisionObjects.size();
  new_aabbs_.resize(static_cast<std::size_t>(count));
  const btVector3 threshold(gContactBreakingThreshold, gContactBreakingThreshold,
                            gContactBreakingThreshold);
  const bool continuous = getDispatchInfo().m_useContinuous;
  forEachIndex(count, kBodiesPerPiece, [&](int i) {
    const btCollisionObject& object = *m_collisionObjects[i];
    if (!m_forceUpdateAllAabbs && !object.isActive()) return;
    NewAabb& aabb = new_aabbs_[static_cast<std::size_t>(i)];
    const btCollisionShape& shape = *object.getCollisionShape();
    shape.getAabb(object.getWorldTransform(), aabb.min, aabb.max);
    aabb.min -= threshold;
    aabb.max += threshold;
    if (continuous && object.getInternalType() == btCollisionObject::CO_RIGID_BODY &&
        !object.isStaticOrKinematicObject()) {
      btVector3 min2, max2;
      shape.getAabb(object.getInterpolationWorldTransform(), min2, max2);
      aabb.min.setMin(min2 - threshold);
      aabb.max.setMax(max2 + threshold);
    }
  });
  // Bullet's updateSingleAabb from here on, object by object.
  for (int i = 0; i < count; ++i) {
    btCollisionObject& object = *m_collisionObjects[i];
    if (!m_forceUpdateAllAabbs && !object.isActive()) continue;
    const NewAabb& aabb = new_aabbs_[static_cast<std::size_t>(i)];
    if (object.isStaticObject() || (aabb.max - aabb.min).length2() < btScalar(1e12)) {
      m_broadphasePairCache->setAabb(object.getBroadphaseHandle(), aabb.min, aabb.max,
                                     m_dispatcher1);
    } else {
      object.setActivationState(DISABLE_SIMULATION);  // Bullet's "overflow in AABB"
    }
  }
}

void TimedDynamicsWorld::integrateTransforms(btScalar dt) {
  const int count = m_nonStaticRigidBodies.size();
  moves_.resize(static_cast<std::size_t>(count));
  forEachIndex(count, kSweepsPerPiece, [&](int i) {
    moves_[static_cast<std::size_t>(i)] = integratedTransform(*m_nonStaticRigidBodies[i], dt);
  });
  // Every sweep above has read the substep's transforms: now each body
  // writes its own (proceedToTransform touches that body alone).
  forEachIndex(count, kBodiesPerPiece, [&](int i) {
    btRigidBody& body = *m_nonStaticRigidBodies[i];
    if (body.isActive() && !body.isStaticOrKinematicObject()) {
      body.proceedToTransform(moves_[static_cast<std::size_t>(i)]);
    }
  });
  // Bullet's speculative restitution pass is left out with the rest of its
  // integrateTransforms: it is off unless asked for, and nothing asks.
}

double TimedDynamicsWorld::ccdQueryMs() const {
  return setup_.ccd_queries != nullptr ? setup_.ccd_queries->queryMs() : 0;
}

btTransform TimedDynamicsWorld::integratedTransform(btRigidBody& body, btScalar dt) const {
  body.setHitFraction(1);
  btTransform predicted = body.getWorldTransform();
  if (!body.isActive() || body.isStaticOrKinematicObject()) return predicted;
  body.predictIntegratedTransform(dt, predicted);
  const btScalar motion2 = (predicted.getOrigin() - body.getWorldTransform().getOrigin()).length2();
  const btScalar threshold2 = body.getCcdSquareMotionThreshold();
  if (getDispatchInfo().m_useContinuous && threshold2 != 0 && threshold2 < motion2 &&
      body.getCollisionShape()->isConvex()) {
    CcdSweep sweep(body, predicted.getOrigin(), *m_broadphasePairCache->getOverlappingPairCache(),
                   *m_dispatcher1, getDispatchInfo().m_allowedCcdPenetration,
                   CcdSweep::Closing::kRelative, dt);
    const btSphereShape sphere(body.getCcdSweptSphereRadius());
    const btTransform to(body.getWorldTransform().getBasis(), predicted.getOrigin());
    convexSweepTest(&sphere, body.getWorldTransform(), to, sweep);
    if (sweep.hasHit() && sweep.m_closestHitFraction < 1) {
      // Up to the hit; the contact there answers in the next substep.
      body.predictIntegratedTransform(dt * sweep.m_closestHitFraction, predicted);
      body.setHitFraction(0);
    }
  }
  return predicted;
}

}  // namespace overlap::physics
