// A Bullet program that links the installed package and nothing else of
// Overlap: a btDiscreteDynamicsWorld whose broadphase is `cpusap`, with a
// pile of 48 boxes dropped onto a ground, stepped 120 times.  After every
// step its pair cache must hold exactly the pairs that `bf`, fed the same
// boxes, finds; a ray cast down the middle must hit.  Prints two lines (what
// `gpubf` runs here, then the check's result) and exits 0, or names the
// first step that differs and exits 1.
#include <btBulletDynamicsCommon.h>
#include <overlap/physics/broadphase/broadphase_factory.h>

#include <cstdio>
#include <memory>
#include <set>
#include <utility>
#include <vector>

namespace {

using Pairs = std::set<std::pair<int, int>>;

// The cache's pairs as the objects' indices in the world, smaller first.
Pairs pairsOf(btBroadphaseInterface& broadphase) {
  Pairs pairs;
  btBroadphasePairArray& array = broadphase.getOverlappingPairCache()->getOverlappingPairArray();
  for (int i = 0; i < array.size(); ++i) {
    const int a =
        static_cast<btCollisionObject*>(array[i].m_pProxy0->m_clientObject)->getWorldArrayIndex();
    const int b =
        static_cast<btCollisionObject*>(array[i].m_pProxy1->m_clientObject)->getWorldArrayIndex();
    pairs.emplace(std::min(a, b), std::max(a, b));
  }
  return pairs;
}

}  // namespace

int main() {
  constexpr int kSide = 4, kLayers = 3, kBoxes = kSide * kSide * kLayers, kSteps = 120;
  const btVector3 world_min(-40, -10, -40), world_max(40, 40, 40);

  // docs/PACKAGE.md's lines: a broadphase by name, in a stock world.
  overlap::physics::BroadphaseChoice choice =
      overlap::physics::makeWorldBroadphase("cpusap", world_min, world_max, kBoxes + 1);
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world(&dispatcher, choice.broadphase.get(), &solver, &config);
  if (choice.name != "cpusap" || !overlap::physics::broadphaseInfo(choice.name).exact) {
    std::fprintf(stderr, "package consumer: got %s (%s)\n", choice.name.c_str(),
                 choice.notice.c_str());
    return 1;
  }

  // A device name: where it cannot run, the notice says why.  A package that
  // gave the finders built without CUDA (Overlap_WITH_CUDA OFF) must never run it.
  const overlap::physics::BroadphaseChoice gpubf =
      overlap::physics::makeWorldBroadphase("gpubf", world_min, world_max, kBoxes + 1);
  std::printf("package consumer: gpubf runs %s%s%s\n", gpubf.name.c_str(),
              gpubf.notice.empty() ? "" : ": ", gpubf.notice.c_str());
  if (!OVERLAP_CONSUMER_GOT_CUDA && (gpubf.name == "gpubf" || gpubf.notice.empty())) {
    std::fprintf(stderr, "package consumer: the finders built without CUDA ran gpubf\n");
    return 1;
  }

  btBoxShape ground_shape(btVector3(20, 1, 20));
  btRigidBody ground(0, nullptr, &ground_shape);
  ground.setWorldTransform(btTransform(btQuaternion::getIdentity(), btVector3(0, -1, 0)));
  world.addRigidBody(&ground);
  btBoxShape box_shape(btVector3(0.5f, 0.5f, 0.5f));
  btVector3 inertia;
  box_shape.calculateLocalInertia(1, inertia);
  std::vector<std::unique_ptr<btDefaultMotionState>> motions;
  std::vector<std::unique_ptr<btRigidBody>> boxes;
  for (int i = 0; i < kBoxes; ++i) {
    const int x = i % kSide, z = (i / kSide) % kSide, y = i / (kSide * kSide);
    // Close enough to touch once they tumble; a slight turn per box so the pile slides.
    const btTransform start(
        btQuaternion(btVector3(1, 0, 1).normalized(), 0.1f * static_cast<float>(i)),
        btVector3(1.1f * static_cast<float>(x) - 1.6f, 1.5f + 1.2f * static_cast<float>(y),
                  1.1f * static_cast<float>(z) - 1.6f));
    motions.push_back(std::make_unique<btDefaultMotionState>(start));
    boxes.push_back(std::make_unique<btRigidBody>(1, motions.back().get(), &box_shape, inertia));
    world.addRigidBody(boxes.back().get());
  }

  // The reference: bf from the same factory, one proxy per object with the world's filters.
  btCollisionDispatcher reference_dispatcher(&config);
  overlap::physics::BroadphaseChoice reference =
      overlap::physics::makeBroadphase("bf", world_min, world_max, kBoxes + 1);
  std::vector<btBroadphaseProxy*> reference_proxies;
  btCollisionObjectArray& objects = world.getCollisionObjectArray();
  for (int i = 0; i < objects.size(); ++i) {
    const btBroadphaseProxy* handle = objects[i]->getBroadphaseHandle();
    reference_proxies.push_back(reference.broadphase->createProxy(
        handle->m_aabbMin, handle->m_aabbMax, BOX_SHAPE_PROXYTYPE, objects[i],
        handle->m_collisionFilterGroup, handle->m_collisionFilterMask, &reference_dispatcher));
  }

  std::size_t pairs_seen = 0;
  for (int step = 0; step < kSteps; ++step) {
    world.stepSimulation(1.0f / 60.0f, 0);
    for (int i = 0; i < objects.size(); ++i) {
      btVector3 lo, hi;
      choice.broadphase->getAabb(objects[i]->getBroadphaseHandle(), lo, hi);
      reference.broadphase->setAabb(reference_proxies[static_cast<std::size_t>(i)], lo, hi,
                                    &reference_dispatcher);
    }
    reference.broadphase->calculateOverlappingPairs(&reference_dispatcher);
    const Pairs found = pairsOf(*choice.broadphase), exact = pairsOf(*reference.broadphase);
    if (found != exact) {
      std::fprintf(stderr, "package consumer: step %d: cpusap holds %zu pairs, bf %zu\n", step,
                   found.size(), exact.size());
      return 1;
    }
    pairs_seen += found.size();
  }

  btCollisionWorld::ClosestRayResultCallback ray(btVector3(0, 30, 0), btVector3(0, -30, 0));
  world.rayTest(ray.m_rayFromWorld, ray.m_rayToWorld, ray);
  if (pairs_seen == 0 || !ray.hasHit()) {
    std::fprintf(stderr, "package consumer: %zu pairs in %d steps, ray %s\n", pairs_seen, kSteps,
                 ray.hasHit() ? "hit" : "missed");
    return 1;
  }
  for (int i = static_cast<int>(boxes.size()) - 1; i >= 0; --i) {
    world.removeRigidBody(boxes[static_cast<std::size_t>(i)].get());
  }
  world.removeRigidBody(&ground);
  std::printf("package consumer: cpusap's pairs equal bf's on all %d steps (%zu pairs in all)\n",
              kSteps, pairs_seen);
  return 0;
}
