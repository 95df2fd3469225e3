#include "physics/island_group.h"

#include <BulletCollision/CollisionDispatch/btSimulationIslandManager.h>

namespace overlap::physics {
namespace {

// Bullet's getIslandId (btSimulationIslandManager.cpp): body 0's island, or
// body 1's when body 0 is on none.
int islandOf(const btPersistentManifold& manifold) {
  const int first = manifold.getBody0()->getIslandTag();
  return first >= 0 ? first : manifold.getBody1()->getIslandTag();
}

}  // namespace

bool IslandGroup::models(btDiscreteDynamicsWorld& world) {
  return world.getNumConstraints() == 0 && world.getSimulationIslandManager()->getSplitIslands();
}

void IslandGroup::gather(btDiscreteDynamicsWorld& world) {
  wakeAndSleepIslands(world);
  gatherManifolds(world);
  gatherIslands(world);
}

// buildIslands' first half: the union-find sorted, then each island's sleep.
void IslandGroup::wakeAndSleepIslands(btDiscreteDynamicsWorld& world) {
  btUnionFind& islands = world.getSimulationIslandManager()->getUnionFind();
  btCollisionObjectArray& objects = world.getCollisionObjectArray();
  islands.sortIslands();
  const int elements = islands.getNumElements();
  for (int begin = 0, end = 0; begin < elements; begin = end) {
    const int island = islands.getElement(begin).m_id;
    for (end = begin + 1; end < elements && islands.getElement(end).m_id == island; ++end) {
    }
    bool all_sleeping = true;
    for (int e = begin; e < end; ++e) {
      const btCollisionObject& object = *objects[islands.getElement(e).m_sz];
      if (object.getIslandTag() == island &&
          (object.getActivationState() == ACTIVE_TAG ||
           object.getActivationState() == DISABLE_DEACTIVATION)) {
        all_sleeping = false;
        break;
      }
    }
    for (int e = begin; e < end; ++e) {
      btCollisionObject& object = *objects[islands.getElement(e).m_sz];
      if (object.getIslandTag() != island) continue;
      if (all_sleeping) {
        object.setActivationState(ISLAND_SLEEPING);
      } else if (object.getActivationState() == ISLAND_SLEEPING) {
        object.setActivationState(WANTS_DEACTIVATION);
        object.setDeactivationTime(0.f);
      }
    }
  }
}

// buildIslands' second half and processIslands' sort.
void IslandGroup::gatherManifolds(btDiscreteDynamicsWorld& world) {
  btDispatcher& dispatcher = *world.getDispatcher();
  const bool deterministic = world.getDispatchInfo().m_deterministicOverlappingPairs;
  keyed_.resize(0);
  for (int m = 0, count = dispatcher.getNumManifolds(); m < count; ++m) {
    btPersistentManifold* manifold = dispatcher.getManifoldByIndexInternal(m);
    if (deterministic && manifold->getNumContacts() == 0) continue;
    auto* first = const_cast<btCollisionObject*>(manifold->getBody0());
    auto* second = const_cast<btCollisionObject*>(manifold->getBody1());
    if (first->getActivationState() == ISLAND_SLEEPING &&
        second->getActivationState() == ISLAND_SLEEPING) {
      continue;
    }
    if (first->isKinematicObject() && first->getActivationState() != ISLAND_SLEEPING &&
        first->hasContactResponse()) {
      second->activate();
    }
    if (second->isKinematicObject() && second->getActivationState() != ISLAND_SLEEPING &&
        second->hasContactResponse()) {
      first->activate();
    }
    if (!dispatcher.needsResponse(first, second)) continue;
    keyed_.push_back({islandOf(*manifold), first->getBroadphaseHandle()->m_uniqueId,
                      second->getBroadphaseHandle()->m_uniqueId, manifold});
  }
  if (deterministic) {
    keyed_.quickSort([](const Keyed& lhs, const Keyed& rhs) {
      return lhs.island < rhs.island || (lhs.island == rhs.island && lhs.first_id < rhs.first_id) ||
             (lhs.island == rhs.island && lhs.first_id == rhs.first_id &&
              lhs.second_id < rhs.second_id);
    });
  } else {
    keyed_.quickSort([](const Keyed& lhs, const Keyed& rhs) { return lhs.island < rhs.island; });
  }
}

// processIslands' walk: each island with an awake body, its bodies and its
// run of the sorted manifolds.
void IslandGroup::gatherIslands(btDiscreteDynamicsWorld& world) {
  btUnionFind& islands = world.getSimulationIslandManager()->getUnionFind();
  btCollisionObjectArray& objects = world.getCollisionObjectArray();
  bodies_.resize(0);
  manifolds_.resize(0);
  const int elements = islands.getNumElements();
  const int count = keyed_.size();
  int next_manifold = 0;
  for (int begin = 0, end = 0; begin < elements; begin = end) {
    const int island = islands.getElement(begin).m_id;
    const int first_body = bodies_.size();
    bool sleeping = true;
    for (end = begin; end < elements && islands.getElement(end).m_id == island; ++end) {
      btCollisionObject* object = objects[islands.getElement(end).m_sz];
      bodies_.push_back(object);
      if (object->isActive()) sleeping = false;
    }
    int run_end = next_manifold;
    if (next_manifold < count && keyed_[next_manifold].island == island) {
      for (run_end = next_manifold + 1; run_end < count && keyed_[run_end].island == island;
           ++run_end) {
      }
    }
    if (sleeping) {
      bodies_.resize(first_body);
    } else {
      for (int m = next_manifold; m < run_end; ++m) manifolds_.push_back(keyed_[m].manifold);
    }
    next_manifold = run_end;
  }
}

}  // namespace overlap::physics
