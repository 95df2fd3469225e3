// Bullet's ghost objects in PhysicsWorld: the pair cache's ghost-pair
// callback slot is shared, so a btPairCachingGhostObject added to
// bulletWorld() sees the boxes that enter it, under every broadphase.
#include <BulletCollision/CollisionDispatch/btGhostObject.h>
#include <btBulletDynamicsCommon.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <string>

#include "physics/broadphase/broadphase_factory.h"
#include "physics/world.h"

namespace overlap::physics {
namespace {

bool overlaps(const Aabb& box, const btVector3& lo, const btVector3& hi) {
  for (int axis = 0; axis < 3; ++axis) {
    if (box.min[axis] > hi[axis] || lo[axis] > box.max[axis]) return false;
  }
  return true;
}

// The boxes (not walls) the ghost's own overlap list holds.
std::set<int> boxesSeenBy(btPairCachingGhostObject& ghost, int boxes) {
  std::set<int> seen;
  for (int i = 0; i < ghost.getNumOverlappingObjects(); ++i) {
    const int index = ghost.getOverlappingObject(i)->getUserIndex();
    if (index >= 0 && index < boxes) seen.insert(index);
  }
  return seen;
}

// Scene 1's boxes fall into a sensor filling the bottom quarter of the
// container.  Exact broadphases pair the ghost with exactly the boxes whose
// AABBs overlap its own; the others (sap, sap32, bvh) with at least those.
TEST(GhostObject, SeesTheBoxesEnteringItUnderEveryBroadphase) {
  constexpr int kBoxes = 150;
  SceneConfig config = SceneConfig::forScene(1);
  config.objects = kBoxes;
  for (const std::string_view name : broadphaseNames()) {
    const std::string algorithm(name);
    PhysicsWorld world(config, WorldOptions{algorithm});
    const bool exact = broadphaseInfo(world.algorithm()).exact;
    const auto h = static_cast<btScalar>(world.layout().half_extent);
    btBoxShape shape(btVector3(h, h / 4, h));
    btPairCachingGhostObject ghost;
    ghost.setCollisionShape(&shape);
    ghost.setWorldTransform(btTransform(btQuaternion::getIdentity(), btVector3(0, -0.75f * h, 0)));
    ghost.setCollisionFlags(ghost.getCollisionFlags() | btCollisionObject::CF_NO_CONTACT_RESPONSE);
    world.bulletWorld().addCollisionObject(
        &ghost, btBroadphaseProxy::SensorTrigger,
        btBroadphaseProxy::AllFilter & ~btBroadphaseProxy::SensorTrigger);
    ASSERT_NE(ghost.getBroadphaseHandle(), nullptr) << algorithm << ": no room for the ghost";
    btVector3 lo, hi;
    ghost.getCollisionShape()->getAabb(ghost.getWorldTransform(), lo, hi);

    world.stepFrame();
    const std::size_t seen_at_start = boxesSeenBy(ghost, kBoxes).size();
    for (int frame = 1; frame < 60; ++frame) world.stepFrame();

    const std::set<int> seen = boxesSeenBy(ghost, kBoxes);
    std::set<int> inside;
    const std::vector<Aabb> boxes = world.aabbs();
    for (int i = 0; i < kBoxes; ++i) {
      if (overlaps(boxes[static_cast<std::size_t>(i)], lo, hi)) inside.insert(i);
    }
    EXPECT_GT(inside.size(), seen_at_start + 20) << algorithm << ": the boxes did not fall in";
    if (exact) {
      EXPECT_EQ(seen, inside) << algorithm;
    } else {
      EXPECT_TRUE(std::includes(seen.begin(), seen.end(), inside.begin(), inside.end()))
          << algorithm;
    }
    // The world's own accounts leave the ghost out: no box counts as sunk in it.
    EXPECT_LT(world.stepFrame().max_penetration, 1.0) << algorithm;
    world.bulletWorld().removeCollisionObject(&ghost);
  }
}

}  // namespace
}  // namespace overlap::physics
