#include "physics/world.h"

#include <BulletCollision/CollisionDispatch/btGhostObject.h>
#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <limits>
#include <span>
#include <stdexcept>
#include <utility>

#include "gpu/base/checksum.h"
#include "gpu/base/interrupt.h"
#include "gpu/base/random.h"
#include "gpu/base/stopwatch.h"
#include "physics/broadphase/broadphase_factory.h"
#include "physics/broadphase/ccd_query_broadphase.h"
#include "physics/broadphase/growing_sweep_and_prune.h"
#include "physics/broadphase/pair_finder_broadphase.h"
#include "physics/coloured_solver.h"
#include "physics/parallel_dispatcher.h"
#include "physics/timed_world.h"

namespace overlap::physics {
namespace {

constexpr int kWallCount = 6;
// Room in the broadphase for objects a user adds to bulletWorld() (ghosts,
// sensors): btSimpleBroadphase and btAxisSweep3 have fixed capacities.
constexpr int kUserObjects = 64;
// Bullet's default collision margin (0.04 m) would round a 0.1 m box's corners
// away almost entirely; a tenth of the edge keeps small boxes box-shaped.
constexpr double kMaxMargin = 0.04;
constexpr double kMarginPerEdge = 0.1;
// A manifold point counts as contact within this distance (m).
constexpr btScalar kContactDistance = 0.01f;
// Past this distance from the origin a float has under 7 cm of resolution, no
// container reaches it, and a box there is a broken state, not a physical one.
constexpr double kFarAway = 1e6;
// Bodies added between two looks at the signal flag (gpu/base/interrupt.h).
constexpr int kBodiesBetweenSignalChecks = 1024;

btVector3 toBullet(const Eigen::Vector3d& v) {
  return {static_cast<btScalar>(v.x()), static_cast<btScalar>(v.y()), static_cast<btScalar>(v.z())};
}

// A vector's three components (not its fourth, unused float).
std::uint64_t hashVector(const btVector3& v, std::uint64_t hash) {
  return fnv1a(std::span<const btScalar>(v.m_floats, 3), hash);
}

}  // namespace

struct PhysicsWorld::Bullet {
  explicit Bullet(TaskSystem& tasks) : dispatcher(&collision_config, tasks) {}

  btDefaultCollisionConfiguration collision_config;
  ParallelDispatcher dispatcher;                   // the narrowphase on the world's task system
  std::unique_ptr<CcdQueryBroadphase> broadphase;  // the pair search, CCD's queries apart
  std::unique_ptr<btConstraintSolver> solver;      // WorldOptions::solver_order's
  std::unique_ptr<TimedDynamicsWorld> world;
  std::vector<std::unique_ptr<btBoxShape>> shapes;
  std::vector<std::unique_ptr<btRigidBody>> bodies;  // boxes, then walls
  std::vector<double> edges;                         // per box
  std::vector<bool> removed;                         // per box: out of the simulation
  btGhostPairCallback ghost_pairs;                   // the pair cache's slot, for ghost objects
  PairList touching;                                 // pairs whose manifold has points
  std::vector<NewContact> new_contacts;              // this frame's
  std::vector<char> ccd;                             // per box: CCD on this frame
  double smallest_edge = INFINITY;
  double typical_edge = 0;  // typicalEdge()
  SeededRandom kick_random{0};
  GravityRotation gravity{0, 0};

  // Linear in the bodies and pairs: removing the bodies one by one
  // (removeRigidBody) would walk the whole pair cache for each body and, for
  // a sweep and prune, sort each body's edges to the end of every axis: n^2.
  ~Bullet() {
    if (world == nullptr) return;
    // Every pair at once, their contact algorithms and manifolds with them.
    struct RemoveEvery final : btOverlapCallback {
      bool processOverlap(btBroadphasePair& /*pair*/) override { return true; }
    } remove_every;
    broadphase->getOverlappingPairCache()->processAllOverlappingPairs(&remove_every, &dispatcher);
    // A sweep and prune frees its handles whole in its destructor: the
    // world's bodies leave it without one removal each.
    if (isSweepAndPrune(broadphase->pairSearch())) {
      for (auto& body : bodies) {
        if (body->getBroadphaseHandle() == nullptr) continue;  // its proxy's creation failed
        broadphase->forgetProxy(body->getBroadphaseHandle());
        body->setBroadphaseHandle(nullptr);
      }
    }
    // The world removes what is left of each body's proxy (its list of
    // bodies is not searched, as removeRigidBody would for each).
    world.reset();
  }
  // True for the world's own boxes and walls, false for objects a user added
  // to bulletWorld() (a ghost object, say).
  bool owns(const btCollisionObject* object) const {
    const int index = object->getUserIndex();
    return index >= 0 && static_cast<std::size_t>(index) < bodies.size() &&
           bodies[static_cast<std::size_t>(index)].get() == object;
  }
  // Visits each contact manifold between two of the world's own bodies (a
  // user object's are left out), CCD's predictive ones included, in the
  // dispatcher's order.
  template <typename Visit>
  void forEachManifold(Visit&& visit) const {
    for (int m = 0; m < dispatcher.getNumManifolds(); ++m) {
      const btPersistentManifold& manifold = *dispatcher.getManifoldByIndexInternal(m);
      if (owns(manifold.getBody0()) && owns(manifold.getBody1())) visit(manifold);
    }
  }
  // The edge of the smaller of two bodies, a wall's being infinite.
  double smallerEdge(int index0, int index1) const {
    const auto edgeOf = [&](int index) {
      return static_cast<std::size_t>(index) < edges.size() ? edges[static_cast<std::size_t>(index)]
                                                            : INFINITY;
    };
    return std::min(edgeOf(index0), edgeOf(index1));
  }
};

PhysicsWorld::PhysicsWorld(const SceneConfig& config, const WorldOptions& options)
    : config_(config),
      layout_(generateScene(config)),
      substeps_(options.substeps),
      automatic_substeps_(options.substeps == kAutoSubsteps),
      ccd_(options.ccd),
      tasks_(options.tasks != nullptr ? *options.tasks : defaultTaskSystem()),
      bullet_(std::make_unique<Bullet>(tasks_)) {
  if (options.substeps < 0) throw std::invalid_argument("substeps: must be at least 1");
  buildWorld(options);
  addBoxes(sleepAllowed(config, options.sleep));
  addWalls();
  recordFrame(nullptr);
}

// The broadphase asked for, Bullet's world around it, the solver's settings
// and the scene's gravity.
void PhysicsWorld::buildWorld(const WorldOptions& options) {
  Bullet& b = *bullet_;
  const auto n = static_cast<int>(layout_.boxes.size());
  // SAP quantizes inside these bounds: the container plus a quarter of margin.
  const btVector3 bound = toBullet(Eigen::Vector3d::Constant(layout_.outerHalfExtent() * 1.25));
  // Counted in the user's boxes: the walls and added objects are ours.
  if (const std::string problem =
          broadphaseCapacityProblem(options.algorithm, n, kWallCount + kUserObjects);
      !problem.empty()) {
    throw std::invalid_argument("algo " + options.algorithm + ": " + problem);
  }
  // The catalogue's world broadphase: the pair search asked for, whose CCD
  // sweeps go through one tree shared by every broadphase, the same queries
  // for all (physics/broadphase/ccd_query_broadphase.h).
  WorldBroadphaseChoice choice =
      makeWorldBroadphase(options.algorithm, -bound, bound, n + kWallCount + kUserObjects, tasks_);
  b.broadphase = std::move(choice.broadphase);
  algorithm_ = choice.name;
  algorithm_notice_ = choice.notice;

  b.dispatcher.setParallel(options.narrowphase != NarrowphaseMode::kBullet);
  TimedWorldSetup setup;
  setup.ccd_queries = b.broadphase.get();
  setup.tasks = &tasks_;
  if (options.narrowphase == NarrowphaseMode::kBesideSearch) {
    setup.search_beside = dynamic_cast<PairFinderBroadphase*>(&b.broadphase->pairSearch());
  }
  setup.after_aabb_update = [this] { removeBrokenBoxes(); };
  setup.after_narrowphase = [this] { noteContactsStarted(); };
  b.solver = makeConstraintSolver(options.solver_order, tasks_);
  b.world = std::make_unique<TimedDynamicsWorld>(&b.dispatcher, b.broadphase.get(), b.solver.get(),
                                                 &b.collision_config, std::move(setup));
  b.world->getDispatchInfo().m_deterministicOverlappingPairs = true;
  applySolverSettings(b.world->getSolverInfo(), options.solver);
  // Bullet's ghost objects (btGhostObject, character controllers) need the
  // pair cache's one ghost-pair slot; the world itself does not use it.
  b.broadphase->getOverlappingPairCache()->setInternalGhostPairCallback(&b.ghost_pairs);
  b.gravity = GravityRotation(config_.g * config_.gravity_scale, config_.rotation_per_frame);
  b.world->setGravity(toBullet(b.gravity.gravity()));
  // A separate stream for the kicks, so scene 2's start equals the others'.
  b.kick_random = SeededRandom(config_.seed ^ 0x9e3779b97f4a7c15ULL);
}

// Box i of the layout as rigid body i.
void PhysicsWorld::addBoxes(bool sleep) {
  Bullet& b = *bullet_;
  const auto n = static_cast<int>(layout_.boxes.size());
  b.bodies.reserve(static_cast<std::size_t>(n + kWallCount));
  for (int i = 0; i < n; ++i) {
    // A sweep and prune inserts a body in time proportional to those it
    // holds: a signal stops the insertion within it.
    if (i % kBodiesBetweenSignalChecks == 0 && pendingInterrupt() != 0) {
      stopIfInterrupted("adding box " + std::to_string(i) + " of " + std::to_string(n) +
                        " to the world");
    }
    const BoxStart& start = layout_.boxes[static_cast<std::size_t>(i)];
    const auto half = static_cast<btScalar>(start.edge / 2);
    auto shape = std::make_unique<btBoxShape>(btVector3(half, half, half));
    shape->setMargin(static_cast<btScalar>(std::min(kMaxMargin, kMarginPerEdge * start.edge)));
    const auto mass = static_cast<btScalar>(start.edge * start.edge * start.edge);
    btVector3 inertia;
    shape->calculateLocalInertia(mass, inertia);
    auto body = std::make_unique<btRigidBody>(mass, nullptr, shape.get(), inertia);
    const Eigen::Quaterniond& q = start.orientation;
    body->setWorldTransform(
        btTransform(btQuaternion(static_cast<btScalar>(q.x()), static_cast<btScalar>(q.y()),
                                 static_cast<btScalar>(q.z()), static_cast<btScalar>(q.w())),
                    toBullet(start.position)));
    body->setLinearVelocity(toBullet(start.velocity));
    body->setUserIndex(i);
    if (!sleep) body->setActivationState(DISABLE_DEACTIVATION);
    // Owned before the world names it: an allocation that fails inside
    // addRigidBody (its proxy) leaves the body in the world's list, and a
    // body freed by the unwinding would be read by the world's destructor.
    b.shapes.push_back(std::move(shape));
    b.bodies.push_back(std::move(body));
    b.edges.push_back(start.edge);
    b.smallest_edge = std::min(b.smallest_edge, start.edge);
    b.removed.push_back(false);
    b.ccd.push_back(0);
    b.world->addRigidBody(b.bodies.back().get());
  }
  b.typical_edge = typicalEdge(b.edges);
}

// Six walls just outside the interior, overlapping at the edges, numbered
// after the boxes.
void PhysicsWorld::addWalls() {
  Bullet& b = *bullet_;
  const auto n = static_cast<int>(layout_.boxes.size());
  const double h = layout_.half_extent;
  const double t = layout_.wall_thickness;
  for (int w = 0; w < kWallCount; ++w) {
    const int axis = w / 2;
    const double side = (w % 2 == 0) ? -1.0 : 1.0;
    Eigen::Vector3d half = Eigen::Vector3d::Constant(h + t);
    half[axis] = t / 2;
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    centre[axis] = side * (h + t / 2);
    auto shape = std::make_unique<btBoxShape>(toBullet(half));
    auto body = std::make_unique<btRigidBody>(0.0f, nullptr, shape.get());
    body->setWorldTransform(btTransform(btQuaternion::getIdentity(), toBullet(centre)));
    body->setUserIndex(n + w);
    b.shapes.push_back(std::move(shape));
    b.bodies.push_back(std::move(body));  // owned before the world names it, as a box
    b.world->addRigidBody(b.bodies.back().get());
  }
}

PhysicsWorld::~PhysicsWorld() = default;

void PhysicsWorld::applySceneForces() {
  Bullet& b = *bullet_;
  const auto n = layout_.boxes.size();
  if (config_.kicks() && n > 0) {
    const auto kicks = std::min<std::size_t>(static_cast<std::size_t>(config_.kicks_per_frame), n);
    std::vector<bool> kicked(n, false);
    const double v = config_.initial_speed;
    for (std::size_t k = 0; k < kicks;) {
      const auto i = static_cast<std::size_t>(b.kick_random.below(n));
      if (kicked[i]) continue;  // distinct objects
      kicked[i] = true;
      ++k;
      const Eigen::Vector3d velocity(b.kick_random.uniform(-v, v), b.kick_random.uniform(-v, v),
                                     b.kick_random.uniform(-v, v));
      b.bodies[i]->activate(true);
      b.bodies[i]->setLinearVelocity(toBullet(velocity));
      if (!b.removed[i]) record_.speeds[i] = b.bodies[i]->getLinearVelocity().length();
    }
  }
  if (config_.rotatingGravity() && frame_ > 0) {
    b.gravity.advanceFrame();
    b.world->setGravity(toBullet(b.gravity.gravity()));
  }
}

std::string PhysicsWorld::substepName(int substep) const {
  return "frame " + std::to_string(frame_) + ", substep " + std::to_string(substep) + " of " +
         std::to_string(substeps_);
}

FrameReport PhysicsWorld::stepFrame() {
  Bullet& b = *bullet_;
  const HostStopwatch frame_watch;
  b.world->beginFrame();
  b.new_contacts.clear();
  applySceneForces();
  FrameReport report;
  planFrame(report);
  const auto dt = static_cast<btScalar>(config_.frame_time / substeps_);
  for (int k = 0; k < substeps_; ++k) {
    // Between substeps the world is whole: a signal stops a long frame there.
    if (k > 0 && pendingInterrupt() != 0) {
      stopIfInterrupted(substepName(k));
    }
    try {
      b.world->stepReported(dt);
    } catch (const Interrupted& stop) {  // inside the substep (its pair search): name the frame
      Interrupted named(stop.signal, substepName(k) + ": " + stop.where);
      named.already_sent = stop.already_sent;
      throw named;
    }
  }
  // The last substep's solver and integration may have broken a box: out now,
  // so that nothing reads it between frames (the next update would be late).
  removeBrokenBoxes();
  report.frame = frame_++;
  report.timings = b.world->timings();
  report.substep_reports = b.world->takeSubsteps();
  report.timings.total_ms = frame_watch.ms();
  report.pairs = b.broadphase->getOverlappingPairCache()->getNumOverlappingPairs();
  recordFrame(&report);
  return report;
}

// This frame's K and CCD bodies (physics/step_policy.h), from the boxes'
// speeds after the scene's kicks and with this frame's gravity.
void PhysicsWorld::planFrame(FrameReport& report) {
  Bullet& b = *bullet_;
  const std::vector<float>& speeds = record_.speeds;  // the kicks' included
  const double gravity = b.world->getGravity().length();
  TopSpeeds all;
  TopSpeeds typical;
  for (std::size_t i = 0; i < speeds.size(); ++i) {
    all.add(speeds[i]);
    if (b.edges[i] >= b.typical_edge)
      typical.add(inTypicalEdges(speeds[i], b.edges[i], b.typical_edge));
  }
  report.fastest_speed = all.fastest;
  if (automatic_substeps_) {
    const FrameMotion motion{all,
                             typical,
                             gravity,
                             config_.frame_time,
                             b.smallest_edge,
                             b.typical_edge,
                             layout_.wall_thickness};
    substeps_ = chooseSubsteps(motion, ccd_ != CcdMode::kOff);
  }
  report.substeps = substeps_;
  const std::vector<char> ccd =
      chooseCcdBodies(ccd_, speeds, b.edges, gravity, config_.frame_time, substeps_);
  for (std::size_t i = 0; i < ccd.size(); ++i) {
    report.ccd_bodies += ccd[i];
    if (ccd[i] == b.ccd[i]) continue;
    b.ccd[i] = ccd[i];
    // Bullet sweeps a body whose motion in a step exceeds the threshold (0: never).
    const double edge = b.edges[i];
    b.bodies[i]->setCcdMotionThreshold(static_cast<btScalar>(ccd[i] ? kCcdShareOfEdge * edge : 0));
    b.bodies[i]->setCcdSweptSphereRadius(static_cast<btScalar>(kCcdSweptSphereShare * edge));
  }
}

namespace {

// Boxes a piece of the record's pass: a box's pose and energy are tens of
// nanoseconds.
constexpr std::size_t kBoxesPerRecordPiece = 1024;

// One piece's counts and sums, merged in piece order: the same totals on any
// number of threads.
struct RecordSums {
  int removed = 0, sleeping = 0, escaped = 0, sunk = 0;
  double kinetic = 0, potential = 0;
};

bool samePose(const BoxPose& a, const BoxPose& b) {
  return std::memcmp(a.centre, b.centre, sizeof a.centre) == 0 &&
         std::memcmp(a.orientation, b.orientation, sizeof a.orientation) == 0;
}

}  // namespace

void PhysicsWorld::recordFrame(FrameReport* report) {
  const Bullet& b = *bullet_;
  const std::size_t n = layout_.boxes.size();
  // The manifolds once: who touches, and the deepest overlap.
  std::vector<char> touching(n, 0);
  double deepest = 0;
  b.forEachManifold([&](const btPersistentManifold& manifold) {
    const int index0 = manifold.getBody0()->getUserIndex();
    const int index1 = manifold.getBody1()->getUserIndex();
    const double edge = b.smallerEdge(index0, index1);
    bool contact = false;
    for (int p = 0; p < manifold.getNumContacts(); ++p) {
      const btScalar distance = manifold.getContactPoint(p).getDistance();
      contact = contact || distance < kContactDistance;
      deepest = std::max(deepest, -distance / edge);
    }
    if (!contact) return;
    for (const int index : {index0, index1}) {
      if (static_cast<std::size_t>(index) < n) touching[static_cast<std::size_t>(index)] = 1;
    }
  });
  record_.deepest_penetration = deepest;
  // The boxes once, on the task system: each writes its own slots.
  const double h = layout_.half_extent;
  const double outer = layout_.outerHalfExtent();
  const btVector3 gravity = b.world->getGravity();
  std::vector<RecordSums> sums(pieceCount(n, kBoxesPerRecordPiece));
  std::vector<char> moved(n, 0);
  const bool first = all_poses_.size() != n;
  all_poses_.resize(n);
  record_.speeds.assign(n, 0.0f);
  tasks_.forEachPiece(n, kBoxesPerRecordPiece, [&](std::size_t first_box, std::size_t end) {
    RecordSums& sum = sums[first_box / kBoxesPerRecordPiece];
    for (std::size_t i = first_box; i < end; ++i) {
      if (b.removed[i]) {
        ++sum.removed;
        continue;
      }
      const btRigidBody& body = *b.bodies[i];
      const btTransform& t = body.getWorldTransform();
      const btVector3& c = t.getOrigin();
      const btQuaternion q = t.getRotation();
      const BoxPose pose{{c.x(), c.y(), c.z()},
                         {q.x(), q.y(), q.z(), q.w()},
                         static_cast<float>(layout_.boxes[i].edge),
                         layout_.boxes[i].size_class,
                         touching[i] != 0};
      moved[i] = first || !samePose(pose, all_poses_[i]) ? 1 : 0;
      all_poses_[i] = pose;
      record_.speeds[i] = body.getLinearVelocity().length();
      if (body.getActivationState() == ISLAND_SLEEPING) ++sum.sleeping;
      const double reach = std::max({std::fabs(c.x()), std::fabs(c.y()), std::fabs(c.z())});
      if (reach > outer) ++sum.escaped;
      if (reach > h) ++sum.sunk;
      const double mass = 1.0 / body.getInvMass();
      const btVector3 spin = body.getAngularVelocity() * t.getBasis();
      const btVector3 rotational = body.getLocalInertia() * spin * spin;  // I w^2 per local axis
      sum.kinetic += 0.5 * (mass * body.getLinearVelocity().length2() + rotational.x() +
                            rotational.y() + rotational.z());
      sum.potential -= mass * gravity.dot(c);
    }
  });
  record_.poses.clear();
  record_.moved.clear();
  for (std::size_t i = 0; i < n; ++i) {
    if (b.removed[i]) continue;
    record_.poses.push_back(all_poses_[i]);
    if (moved[i] != 0) record_.moved.push_back(static_cast<int>(i));
  }
  record_.began = b.new_contacts;
  if (report == nullptr) return;
  for (const RecordSums& sum : sums) {
    report->removed_from_simulation += sum.removed;
    report->sleeping += sum.sleeping;
    report->escaped += sum.escaped;
    report->sunk += sum.sunk;
    report->kinetic_energy += sum.kinetic;
    report->potential_energy += sum.potential;
  }
  report->max_penetration = deepest;
}

std::uint64_t PhysicsWorld::stateHash() const {
  std::uint64_t hash = kFnv1aOffsetBasis;
  for (std::size_t i = 0; i < layout_.boxes.size(); ++i) {
    const btRigidBody& body = *bullet_->bodies[i];
    const btTransform& t = body.getWorldTransform();
    hash = hashVector(t.getOrigin(), hash);
    for (int r = 0; r < 3; ++r) hash = hashVector(t.getBasis()[r], hash);
    hash = hashVector(body.getLinearVelocity(), hash);
    hash = hashVector(body.getAngularVelocity(), hash);
  }
  return hash;
}

std::uint64_t PhysicsWorld::contactHash() const {
  const btCollisionDispatcher& dispatcher = bullet_->dispatcher;
  std::uint64_t hash = kFnv1aOffsetBasis;
  for (int m = 0; m < dispatcher.getNumManifolds(); ++m) {
    const btPersistentManifold& manifold = *dispatcher.getManifoldByIndexInternal(m);
    const int head[] = {manifold.getBody0()->getUserIndex(), manifold.getBody1()->getUserIndex(),
                        manifold.getNumContacts()};
    hash = fnv1a(std::span<const int>(head), hash);
    for (int p = 0; p < manifold.getNumContacts(); ++p) {
      const btManifoldPoint& point = manifold.getContactPoint(p);
      for (const btVector3* v :
           {&point.m_localPointA, &point.m_localPointB, &point.m_positionWorldOnA,
            &point.m_positionWorldOnB, &point.m_normalWorldOnB}) {
        hash = hashVector(*v, hash);
      }
      const btScalar values[] = {point.m_distance1, point.m_appliedImpulse};
      hash = fnv1a(std::span<const btScalar>(values), hash);
      hash = fnv1a(std::span<const int>(&point.m_lifeTime, 1), hash);
    }
  }
  return hash;
}

std::vector<Aabb> PhysicsWorld::aabbs() const {
  std::vector<Aabb> result;
  result.reserve(bullet_->bodies.size());
  for (const auto& body : bullet_->bodies) {
    if (body->getBroadphaseHandle() == nullptr) {  // out of the simulation: overlaps nothing
      constexpr float kInf = std::numeric_limits<float>::infinity();
      result.push_back(Aabb{{kInf, kInf, kInf}, {-kInf, -kInf, -kInf}});
      continue;
    }
    btVector3 lo, hi;
    bullet_->broadphase->getAabb(body->getBroadphaseHandle(), lo, hi);
    result.push_back(Aabb{{lo.x(), lo.y(), lo.z()}, {hi.x(), hi.y(), hi.z()}});
  }
  return result;
}

PairList PhysicsWorld::cachedPairs() const {
  btOverlappingPairCache& cache = *bullet_->broadphase->getOverlappingPairCache();
  PairList pairs;
  pairs.reserve(static_cast<std::size_t>(cache.getNumOverlappingPairs()));
  const btBroadphasePairArray& array = cache.getOverlappingPairArray();
  for (int i = 0; i < array.size(); ++i) {
    const auto* a = static_cast<const btCollisionObject*>(array[i].m_pProxy0->m_clientObject);
    const auto* c = static_cast<const btCollisionObject*>(array[i].m_pProxy1->m_clientObject);
    if (!bullet_->owns(a) || !bullet_->owns(c)) continue;  // a ghost's
    pairs.push_back(orderedPair(a->getUserIndex(), c->getUserIndex()));
  }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

void PhysicsWorld::removeBrokenBoxes() {
  Bullet& b = *bullet_;
  for (std::size_t i = 0; i < layout_.boxes.size(); ++i) {
    if (b.removed[i]) continue;
    btRigidBody& body = *b.bodies[i];
    const btVector3& c = body.getWorldTransform().getOrigin();
    const bool disabled = body.getActivationState() == DISABLE_SIMULATION;
    const bool lost = !(c.length() <= kFarAway);  // NaN and infinity fail the test too
    if (!disabled && !lost) continue;
    // Out now, before the narrowphase meets its state: a NaN contact would
    // spread to every box it touches through the solver.
    b.world->removeBody(body);
    b.removed[i] = true;
    std::fprintf(
        stderr, "overlap: box %zu left the simulation at frame %d: centre (%g, %g, %g) is %s\n", i,
        frame_, c.x(), c.y(), c.z(),
        !(std::isfinite(c.x()) && std::isfinite(c.y()) && std::isfinite(c.z())) ? "not finite"
        : disabled ? "inside an AABB too large for Bullet"
                   : "too far from the origin");
    // Nor may a contact it began this frame be reported.
    const int box = static_cast<int>(i);
    std::erase_if(b.new_contacts, [box](const NewContact& contact) {
      return contact.a == box || contact.b == box;
    });
  }
}

// After each narrowphase: the pairs whose manifold has points now and had
// none after the last one began touching.  Their speeds are read before the
// solver, at impact.
void PhysicsWorld::noteContactsStarted() {
  Bullet& b = *bullet_;
  PairList touching;
  b.forEachManifold([&](const btPersistentManifold& manifold) {
    if (manifold.getNumContacts() == 0) return;
    touching.push_back(
        orderedPair(manifold.getBody0()->getUserIndex(), manifold.getBody1()->getUserIndex()));
  });
  std::sort(touching.begin(), touching.end());
  touching.erase(std::unique(touching.begin(), touching.end()), touching.end());
  PairList began;
  std::set_difference(touching.begin(), touching.end(), b.touching.begin(), b.touching.end(),
                      std::back_inserter(began));
  b.touching = std::move(touching);

  const auto n = static_cast<int>(layout_.boxes.size());
  for (const finders::IndexPair& pair : began) {
    const auto index0 = static_cast<int>(pair.a);
    const auto index1 = static_cast<int>(pair.b);
    const btRigidBody& body0 = *b.bodies[pair.a];
    const btRigidBody& body1 = *b.bodies[pair.b];
    const btVector3& c0 = body0.getWorldTransform().getOrigin();
    const btVector3& c1 = body1.getWorldTransform().getOrigin();
    // Boxes close along the line between their centres; a box closes on a
    // wall (always index1, numbered after the boxes) along the wall's normal.
    btVector3 line = c1 - c0;
    if (index1 >= n) {
      const int axis = (index1 - n) / 2;
      line = btVector3(0, 0, 0);
      line[axis] = c1[axis];
    }
    const btScalar length = line.length();
    const btScalar closing =
        length > 0 ? (body0.getLinearVelocity() - body1.getLinearVelocity()).dot(line) / length : 0;
    b.new_contacts.push_back(NewContact{index0,
                                        index1,
                                        std::max(0.0f, closing),
                                        {c0.x(), c0.y(), c0.z()},
                                        static_cast<float>(b.smallerEdge(index0, index1))});
  }
}

void PhysicsWorld::injectBoxPosition(int box, const Eigen::Vector3d& position) {
  if (box < 0 || box >= static_cast<int>(layout_.boxes.size())) {
    throw std::out_of_range("injectBoxPosition: no box " + std::to_string(box));
  }
  btRigidBody& body = *bullet_->bodies[static_cast<std::size_t>(box)];
  body.getWorldTransform().setOrigin(toBullet(position));
  body.activate(true);
  removeBrokenBoxes();
  recordFrame(nullptr);
}

btDiscreteDynamicsWorld& PhysicsWorld::bulletWorld() {
  return *bullet_->world;
}
btBroadphaseInterface& PhysicsWorld::broadphase() {
  return bullet_->broadphase->pairSearch();
}

}  // namespace overlap::physics
