#include "physics/parallel_dispatcher.h"

#include <BulletCollision/CollisionDispatch/btBoxBoxCollisionAlgorithm.h>

#include <typeinfo>

#include "physics/broadphase/bulk_pair_cache.h"

namespace overlap::physics {
namespace {

// Pairs a piece: a box-box pair's contacts take a few microseconds.
constexpr std::size_t kPairsPerPiece = 32;

bool globalContactCallbackSet() {
  return gContactAddedCallback != nullptr || gContactProcessedCallback != nullptr ||
         gContactDestroyedCallback != nullptr || gContactStartedCallback != nullptr ||
         gContactEndedCallback != nullptr;
}

btCollisionObject* objectOf(const btBroadphaseProxy* proxy) {
  return static_cast<btCollisionObject*>(proxy->m_clientObject);
}

// What btCollisionDispatcher::defaultNearCallback does for a pair whose
// algorithm is found: the contacts of the two bodies as they stand.
void processPair(btBroadphasePair& pair, const btDispatcherInfo& info) {
  btCollisionObject* a = objectOf(pair.m_pProxy0);
  btCollisionObject* b = objectOf(pair.m_pProxy1);
  const btCollisionObjectWrapper wrap_a(nullptr, a->getCollisionShape(), a, a->getWorldTransform(),
                                        -1, -1);
  const btCollisionObjectWrapper wrap_b(nullptr, b->getCollisionShape(), b, b->getWorldTransform(),
                                        -1, -1);
  btManifoldResult contacts(&wrap_a, &wrap_b);
  pair.m_algorithm->processCollision(&wrap_a, &wrap_b, info, &contacts);
}

bool isBoxBox(const btCollisionAlgorithm& algorithm) {
  return typeid(algorithm) == typeid(btBoxBoxCollisionAlgorithm);
}

// Whether dispatchStayingPairs ran a pair that needs collision and is in the
// cache after the search: exactly the box-box pairs with an algorithm, since
// the search gives the pairs it adds none (the serial pass finds theirs) and
// changes no other pair's (a removal frees only the removed pair's).
bool ranBesideSearch(const btBroadphasePair& pair) {
  return pair.m_algorithm != nullptr && isBoxBox(*pair.m_algorithm);
}

}  // namespace

// The serial part of a dispatch, in the cache's visit order: Bullet's near
// callback, except that a box-box pair's processCollision is collected for
// the parallel part instead of run (and, after dispatchStayingPairs, a
// box-box pair that came with its algorithm is skipped: the first half ran
// it).
class ParallelDispatcher::SerialPass final : public btOverlapCallback {
 public:
  SerialPass(ParallelDispatcher& dispatcher, const btDispatcherInfo& info)
      : dispatcher_(dispatcher), info_(info) {}

  bool processOverlap(btBroadphasePair& pair) override {
    btCollisionObject* a = objectOf(pair.m_pProxy0);
    btCollisionObject* b = objectOf(pair.m_pProxy1);
    if (!dispatcher_.needsCollision(a, b)) return false;
    if (dispatcher_.staying_ran_ && ranBesideSearch(pair)) return false;
    const btCollisionObjectWrapper wrap_a(nullptr, a->getCollisionShape(), a,
                                          a->getWorldTransform(), -1, -1);
    const btCollisionObjectWrapper wrap_b(nullptr, b->getCollisionShape(), b,
                                          b->getWorldTransform(), -1, -1);
    if (pair.m_algorithm == nullptr) {
      pair.m_algorithm =
          dispatcher_.findAlgorithm(&wrap_a, &wrap_b, nullptr, BT_CONTACT_POINT_ALGORITHMS);
    }
    if (pair.m_algorithm == nullptr) return false;
    if (isBoxBox(*pair.m_algorithm)) {
      dispatcher_.box_pairs_.push_back(&pair);
    } else {
      btManifoldResult contacts(&wrap_a, &wrap_b);
      pair.m_algorithm->processCollision(&wrap_a, &wrap_b, info_, &contacts);
    }
    return false;  // never removes the pair
  }

 private:
  ParallelDispatcher& dispatcher_;
  const btDispatcherInfo& info_;
};

ParallelDispatcher::ParallelDispatcher(btCollisionConfiguration* config, TaskSystem& tasks)
    : btCollisionDispatcher(config), tasks_(tasks) {}

bool ParallelDispatcher::dispatchesInParallel(const btDispatcherInfo& info) const {
  return parallel_ && tasks_.threads() > 1 && getNearCallback() == &defaultNearCallback &&
         info.m_dispatchFunc == btDispatcherInfo::DISPATCH_DISCRETE && !globalContactCallbackSet();
}

void ParallelDispatcher::dispatchAllCollisionPairs(btOverlappingPairCache* cache,
                                                   const btDispatcherInfo& info,
                                                   btDispatcher* dispatcher) {
  last_parallel_pairs_ = 0;
  if (!dispatchesInParallel(info)) {
    btCollisionDispatcher::dispatchAllCollisionPairs(cache, info, dispatcher);
    return;
  }
  staying_ran_ = false;
  dispatchRemainingPairs(cache, info);
}

void ParallelDispatcher::dispatchStayingPairs(btOverlappingPairCache* cache,
                                              const btDispatcherInfo& info) {
  last_parallel_pairs_ = 0;
  box_pairs_.clear();
  // Reads only: the search may not change the cache until this returns.
  btBroadphasePairArray& pairs = cache->getOverlappingPairArray();
  for (int i = 0; i < pairs.size(); ++i) {
    btBroadphasePair& pair = pairs[i];
    if (ranBesideSearch(pair) &&
        needsCollision(objectOf(pair.m_pProxy0), objectOf(pair.m_pProxy1))) {
      box_pairs_.push_back(&pair);
    }
  }
  staying_ran_ = true;
  processInParallel(info);
}

void ParallelDispatcher::dispatchRemainingPairs(btOverlappingPairCache* cache,
                                                const btDispatcherInfo& info) {
  box_pairs_.clear();
  SerialPass pass(*this, info);
  if (auto* bulk = dynamic_cast<BulkPairCache*>(cache)) {
    // The pairs with serial work (new ones, and those of other algorithms)
    // visited in the cache's order; the box-box pairs with an algorithm
    // have none, so they are not sorted with them.
    serial_pairs_.clear();
    btBroadphasePairArray& pairs = cache->getOverlappingPairArray();
    for (int i = 0; i < pairs.size(); ++i) {
      btBroadphasePair& pair = pairs[i];
      if (!ranBesideSearch(pair)) {
        serial_pairs_.push_back(i);
      } else if (!staying_ran_ &&
                 needsCollision(objectOf(pair.m_pProxy0), objectOf(pair.m_pProxy1))) {
        box_pairs_.push_back(&pair);
      }
    }
    bulk->processPairsInVisitOrder(serial_pairs_, &pass, info);
  } else {
    cache->processAllOverlappingPairs(&pass, this, info);
  }
  processInParallel(info);
  staying_ran_ = false;
}

void ParallelDispatcher::processInParallel(const btDispatcherInfo& info) {
  last_parallel_pairs_ += static_cast<int>(box_pairs_.size());
  tasks_.forEachPiece(box_pairs_.size(), kPairsPerPiece, [&](std::size_t first, std::size_t end) {
    for (std::size_t i = first; i < end; ++i) processPair(*box_pairs_[i], info);
  });
  box_pairs_.clear();
}

}  // namespace overlap::physics
