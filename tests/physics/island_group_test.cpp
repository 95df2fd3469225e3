// Bullet's islands solved as one group (physics/island_group.h): the world
// steps to the bits of Bullet's own btDiscreteDynamicsWorld, whose island
// callback solves them in batches, with Bullet's serial solver and with the
// coloured one unsplit (split, its regions span islands), through islands
// that fall asleep, wake, and are woken by a kinematic body.
#include "physics/island_group.h"

#include <btBulletDynamicsCommon.h>
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "gpu/task_system.h"
#include "physics/coloured_solver.h"
#include "physics/timed_world.h"

namespace overlap::physics {
namespace {

enum class Solver { kBullet, kUnsplitColoured };

// One world: a floor, three piles of boxes apart from each other (one of
// them falls asleep before the kinematic box pushes into it), a lone box,
// and the kinematic box, which starts moving at step 150.
struct World {
  btBoxShape box{btVector3(0.5f, 0.5f, 0.5f)};
  btBoxShape floor_shape{btVector3(60, 1, 60)};
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  std::unique_ptr<TaskSystem> tasks;
  std::unique_ptr<btConstraintSolver> solver;
  std::unique_ptr<btDiscreteDynamicsWorld> world;
  std::vector<std::unique_ptr<btDefaultMotionState>> motions;
  std::vector<std::unique_ptr<btRigidBody>> bodies;
  btRigidBody* kinematic = nullptr;

  World(bool bullets_islands, Solver kind) {
    tasks = makeTaskSystem(2);
    if (kind == Solver::kUnsplitColoured) {
      solver = std::make_unique<ColouredConstraintSolver>(*tasks,
                                                          ColouredConstraintSolver::Split::kNone);
    } else {
      solver = std::make_unique<btSequentialImpulseConstraintSolver>();
    }
    if (bullets_islands) {
      world = std::make_unique<btDiscreteDynamicsWorld>(&dispatcher, &broadphase, solver.get(),
                                                        &config);
    } else {
      world = std::make_unique<TimedDynamicsWorld>(&dispatcher, &broadphase, solver.get(), &config);
    }
    world->getDispatchInfo().m_deterministicOverlappingPairs = true;
    world->setGravity(btVector3(0, -9.8f, 0));
    add(floor_shape, 0, btVector3(0, -1, 0));
    // Three piles 20 m apart, of 60, 24 and 8 boxes, in loose columns.
    const int piles[] = {60, 24, 8};
    for (int pile = 0; pile < 3; ++pile) {
      for (int i = 0; i < piles[pile]; ++i) {
        const auto f = [](int n) { return static_cast<btScalar>(n); };
        const btVector3 at(-20.0f + 20.0f * f(pile) + 1.1f * f(i % 4), 0.6f + 1.05f * f(i / 16),
                           1.1f * f((i / 4) % 4) + 0.01f * f(i));
        add(box, 1, at);
      }
    }
    add(box, 1, btVector3(0, 12, -20));  // the lone box
    kinematic = add(box, 0, btVector3(-4, 0.5f, 1.5f));
    kinematic->setCollisionFlags(kinematic->getCollisionFlags() |
                                 btCollisionObject::CF_KINEMATIC_OBJECT);
    kinematic->setActivationState(DISABLE_DEACTIVATION);
  }
  ~World() {
    for (auto& body : bodies) world->removeRigidBody(body.get());
  }

  btRigidBody* add(btBoxShape& shape, btScalar mass, const btVector3& at) {
    btVector3 inertia(0, 0, 0);
    if (mass > 0) shape.calculateLocalInertia(mass, inertia);
    auto& motion = motions.emplace_back(
        std::make_unique<btDefaultMotionState>(btTransform(btQuaternion::getIdentity(), at)));
    btRigidBody::btRigidBodyConstructionInfo info(mass, motion.get(), &shape, inertia);
    btRigidBody* body = bodies.emplace_back(std::make_unique<btRigidBody>(info)).get();
    world->addRigidBody(body);
    return body;
  }

  void step(int index) {
    if (index >= 150) {
      btTransform pose;
      kinematic->getMotionState()->getWorldTransform(pose);
      pose.setOrigin(pose.getOrigin() + btVector3(0.02f, 0, 0));
      kinematic->getMotionState()->setWorldTransform(pose);
    }
    world->stepSimulation(1.0f / 60, 0);
  }
};

std::uint32_t bits(btScalar value) {
  return std::bit_cast<std::uint32_t>(value);
}

// The first difference between the two worlds' bodies, or "".
std::string firstDifference(const World& bullet, const World& ours) {
  const auto vector = [](const btVector3& v) {
    return std::vector<std::uint32_t>{bits(v.x()), bits(v.y()), bits(v.z())};
  };
  for (std::size_t i = 0; i < bullet.bodies.size(); ++i) {
    const btRigidBody& a = *bullet.bodies[i];
    const btRigidBody& b = *ours.bodies[i];
    const btTransform& pa = a.getWorldTransform();
    const btTransform& pb = b.getWorldTransform();
    const std::string body = "body " + std::to_string(i) + ": ";
    if (vector(pa.getOrigin()) != vector(pb.getOrigin())) return body + "position";
    for (int row = 0; row < 3; ++row) {
      if (vector(pa.getBasis()[row]) != vector(pb.getBasis()[row])) return body + "rotation";
    }
    if (vector(a.getLinearVelocity()) != vector(b.getLinearVelocity())) return body + "speed";
    if (vector(a.getAngularVelocity()) != vector(b.getAngularVelocity())) return body + "spin";
    if (a.getActivationState() != b.getActivationState()) return body + "activation";
  }
  return "";
}

class IslandGroupTest : public ::testing::TestWithParam<Solver> {};

TEST_P(IslandGroupTest, OneGroupStepsToTheBitsOfBulletsIslandBatches) {
  World bullet(true, GetParam());
  World ours(false, GetParam());
  int sleeping_seen = 0;
  int woken_seen = 0;
  int previous_sleeping = 0;
  for (int step = 0; step < 400; ++step) {
    bullet.step(step);
    ours.step(step);
    ASSERT_EQ(firstDifference(bullet, ours), "") << "step " << step;
    int sleeping = 0;
    for (const auto& body : ours.bodies) sleeping += body->getActivationState() == ISLAND_SLEEPING;
    sleeping_seen = std::max(sleeping_seen, sleeping);
    if (sleeping < previous_sleeping) ++woken_seen;
    previous_sleeping = sleeping;
  }
  // The run went through what the group must model.
  EXPECT_GT(sleeping_seen, 8) << "no pile fell asleep";
  EXPECT_GT(woken_seen, 0) << "the kinematic box woke nothing";
  EXPECT_TRUE(IslandGroup::models(*ours.world));
}

INSTANTIATE_TEST_SUITE_P(Solvers, IslandGroupTest,
                         ::testing::Values(Solver::kBullet, Solver::kUnsplitColoured),
                         [](const ::testing::TestParamInfo<Solver>& param) {
                           return std::string(param.param == Solver::kBullet
                                                  ? "BulletsSerialSolver"
                                                  : "UnsplitColouredSolver");
                         });

}  // namespace
}  // namespace overlap::physics
