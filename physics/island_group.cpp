#include "physics/island_group.h"

#include <BulletCollision/CollisionDispatch/btSimulationIslandManager.h>

#include <algorithm>
#include <bit>

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
    if (!sortByPackedKeys()) {
      keyed_.quickSort([](const Keyed& lhs, const Keyed& rhs) {
        return lhs.island < rhs.island ||
               (lhs.island == rhs.island && lhs.first_id < rhs.first_id) ||
               (lhs.island == rhs.island && lhs.first_id == rhs.first_id &&
                lhs.second_id < rhs.second_id);
      });
    }
  } else {
    keyed_.quickSort([](const Keyed& lhs, const Keyed& rhs) { return lhs.island < rhs.island; });
  }
}

// Bullet's quickSort of the three-part keys, run on one integer per key:
// each part fits in at most 31 bits, so the packed key orders as the parts
// do, and Bullet's algorithm, answered alike at every comparison, makes the
// same permutation, ties included (CCD's predictive manifolds share their
// pair's key).  At 3500 boxes the sort was the solver stage's largest serial
// part.
bool IslandGroup::sortByPackedKeys() {
  const int count = keyed_.size();
  int max_island = 0;
  int max_first = 0;
  int max_second = 0;
  for (int m = 0; m < count; ++m) {
    const Keyed& keyed = keyed_[m];
    if (keyed.island < 0 || keyed.first_id < 0 || keyed.second_id < 0) return false;
    max_island = std::max(max_island, keyed.island);
    max_first = std::max(max_first, keyed.first_id);
    max_second = std::max(max_second, keyed.second_id);
  }
  const auto bits = [](int value) { return std::bit_width(static_cast<unsigned>(value)); };
  const int second_bits = bits(max_second);
  const int first_shift = second_bits;
  const int island_shift = first_shift + bits(max_first);
  if (island_shift + bits(max_island) > 64) return false;
  if (count == 0) return true;
  packed_.resizeNoInitialize(count);
  for (int m = 0; m < count; ++m) {
    const Keyed& keyed = keyed_[m];
    packed_[m] = {(std::uint64_t{static_cast<unsigned>(keyed.island)} << island_shift) |
                      (std::uint64_t{static_cast<unsigned>(keyed.first_id)} << first_shift) |
                      static_cast<unsigned>(keyed.second_id),
                  keyed.manifold};
  }
  // The same algorithm on the same sequence, each comparison answered alike:
  // the same permutation, ties included.
  packed_.quickSort([](const Packed& lhs, const Packed& rhs) { return lhs.key < rhs.key; });
  const std::uint64_t first_mask = (std::uint64_t{1} << (island_shift - first_shift)) - 1;
  const std::uint64_t second_mask = (std::uint64_t{1} << second_bits) - 1;
  for (int m = 0; m < count; ++m) {
    const Packed& packed = packed_[m];
    keyed_[m] = {static_cast<int>(packed.key >> island_shift),
                 static_cast<int>((packed.key >> first_shift) & first_mask),
                 static_cast<int>(packed.key & second_mask), packed.manifold};
  }
  return true;
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
