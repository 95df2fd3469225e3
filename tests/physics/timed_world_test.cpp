// The world PhysicsWorld steps: Bullet's CCD clamp repaired (physics/timed_world.h).
#include "physics/timed_world.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <utility>
#include <vector>

namespace overlap::physics {
namespace {

// Two 1 m boxes falling side by side at 160-170 m/s under 50 g, both with CCD
// (threshold half an edge, sphere 0.4 edge): boxes 2677 and 1260 of scene 3
// at 3500 boxes (seed 42, K = 8, --ccd auto) at the start of frame 10, copied
// to the digit.  Nothing else is within 2.5 m of them.
struct FallingPair {
  btBoxShape shape{btVector3(0.5f, 0.5f, 0.5f)};
  std::vector<std::unique_ptr<btRigidBody>> bodies;
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  std::unique_ptr<btDiscreteDynamicsWorld> world;

  template <class World>
  explicit FallingPair(std::type_identity<World>)
      : world(std::make_unique<World>(&dispatcher, &broadphase, &solver, &config)) {
    addBoth();
  }
  explicit FallingPair(TimedWorldSetup setup)
      : world(std::make_unique<TimedDynamicsWorld>(&dispatcher, &broadphase, &solver, &config,
                                                   std::move(setup))) {
    addBoth();
  }
  void addBoth() {
    world->setGravity(btVector3(0, -50 * 9.798f, 0));
    shape.setMargin(0.04f);
    applySolverSettings(world->getSolverInfo(), SolverMode::kPile);
    add({-8.15285683f, -7.18443775f, 0.355216444f},
        {0.267163128f, -0.681353688f, 0.222343713f, 0.644161582f},
        {-0.38555333f, -160.767609f, 1.95906401f}, {9.69750977f, 0.957460165f, 5.94018126f});
    add({-7.21603441f, -7.13103628f, -0.205163434f},
        {-0.103274643f, -0.341462404f, 0.865176558f, -0.352430463f},
        {4.16733742f, -170.063507f, -4.63916445f}, {1.92037964f, -0.990813911f, 4.39872646f});
  }
  ~FallingPair() {
    for (auto& body : bodies) world->removeRigidBody(body.get());
  }

  void add(const btVector3& position, const btQuaternion& rotation, const btVector3& velocity,
           const btVector3& spin) {
    btVector3 inertia;
    shape.calculateLocalInertia(1, inertia);
    btRigidBody::btRigidBodyConstructionInfo info(1, nullptr, &shape, inertia);
    info.m_startWorldTransform = btTransform(rotation, position);
    auto& body = bodies.emplace_back(std::make_unique<btRigidBody>(info));
    body->setLinearVelocity(velocity);
    body->setAngularVelocity(spin);
    body->setActivationState(DISABLE_DEACTIVATION);
    body->setCcdMotionThreshold(0.5f);
    body->setCcdSweptSphereRadius(0.4f);
    world->addRigidBody(body.get());
  }

  // How far each box falls in one 1/30 s frame of 8 substeps.
  std::vector<double> fallInOneFrame() {
    std::vector<double> before;
    for (auto& body : bodies) before.push_back(body->getWorldTransform().getOrigin().y());
    for (int k = 0; k < 8; ++k) world->stepSimulation(1.0f / 240, 0);
    std::vector<double> fall;
    for (std::size_t i = 0; i < bodies.size(); ++i) {
      fall.push_back(before[i] - bodies[i]->getWorldTransform().getOrigin().y());
    }
    return fall;
  }
};

TEST(TimedDynamicsWorld, BulletsCcdClampFreezesTwoBoxesFallingSideBySide) {
  // The negative control: Bullet's own clamp stops each box where its sweep
  // meets the other, as if the other stood still (the two overlap, and with
  // the pile solver's push-out in the velocity solve each sweep meets the
  // other at once); they hang in the air frame after frame while gravity
  // adds 16 m/s a frame to their speed.
  FallingPair pair(std::type_identity<btDiscreteDynamicsWorld>{});
  for (int frame = 0; frame < 3; ++frame) {
    for (const double fall : pair.fallInOneFrame()) EXPECT_LT(fall, 0.05) << frame;
  }
  EXPECT_GT(-pair.bodies[1]->getLinearVelocity().y(), 170 + 3 * 16.0);
}

TEST(TimedDynamicsWorld, CcdBoxesFallingSideBySideKeepFalling) {
  // The repaired clamp stops a box only where it closes on what it hits:
  // each box falls freely, its speed times the frame and up to g T^2 more.
  FallingPair pair(std::type_identity<TimedDynamicsWorld>{});
  const std::vector<double> fall = pair.fallInOneFrame();
  const double speeds[] = {160.767609, 170.063507};
  const double frame = 1.0 / 30;
  for (int i = 0; i < 2; ++i) {
    EXPECT_GT(fall[i], speeds[i] * frame) << i;
    EXPECT_LT(fall[i], speeds[i] * frame + 50 * 9.798 * frame * frame) << i;
  }
}

// The manifolds of the dispatcher that name `body`.
int manifoldsNaming(btDispatcher& dispatcher, const btCollisionObject* body) {
  int count = 0;
  for (int m = 0; m < dispatcher.getNumManifolds(); ++m) {
    const btPersistentManifold* manifold = dispatcher.getManifoldByIndexInternal(m);
    count += manifold->getBody0() == body || manifold->getBody1() == body;
  }
  return count;
}

TEST(TimedDynamicsWorld, ABodyRemovedMidSubstepLeavesNoContactOrConstraintNamingIt) {
  // Removed where PhysicsWorld removes a broken box, after the AABB update:
  // CCD's predictive contacts of this substep already name it, and Bullet
  // keeps them apart from the pairs, so removeRigidBody alone leaves them.
  // In the first substep the search has not run yet, so every manifold then
  // is a predictive one.
  TimedDynamicsWorld* world = nullptr;
  btRigidBody* leaving = nullptr;
  int named_before = -1;
  int named_after = -1;
  TimedWorldSetup setup;
  setup.after_aabb_update = [&] {
    if (named_before >= 0) return;  // the first substep only
    named_before = manifoldsNaming(*world->getDispatcher(), leaving);
    world->removeBody(*leaving);
    named_after = manifoldsNaming(*world->getDispatcher(), leaving);
  };
  FallingPair pair(std::move(setup));
  world = static_cast<TimedDynamicsWorld*>(pair.world.get());
  world->getDispatchInfo().m_deterministicOverlappingPairs = true;  // as PhysicsWorld sets it
  leaving = pair.bodies[1].get();
  btRigidBody& staying = *pair.bodies[0];
  btPoint2PointConstraint link(*leaving, staying, btVector3(0, 0, 0), btVector3(0, 2, 0));
  world->addConstraint(&link);
  for (int k = 0; k < 8; ++k) world->stepSimulation(1.0f / 240, 0);

  ASSERT_GT(named_before, 0) << "the test needs a predictive contact naming the body";
  EXPECT_EQ(named_after, 0);
  EXPECT_EQ(manifoldsNaming(*world->getDispatcher(), leaving), 0);
  EXPECT_EQ(world->getNumConstraints(), 0);
  EXPECT_EQ(world->getNumCollisionObjects(), 1);
  EXPECT_EQ(leaving->getBroadphaseHandle(), nullptr);
  const btVector3& centre = staying.getWorldTransform().getOrigin();
  EXPECT_TRUE(std::isfinite(centre.x()) && std::isfinite(centre.y()) && std::isfinite(centre.z()));
}

}  // namespace
}  // namespace overlap::physics
