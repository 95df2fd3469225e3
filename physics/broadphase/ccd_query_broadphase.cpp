#include "physics/broadphase/ccd_query_broadphase.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "gpu/base/stopwatch.h"

namespace overlap::physics {

class CcdQueryBroadphase::ForwardRay final : public btBroadphaseRayCallback {
 public:
  explicit ForwardRay(btBroadphaseRayCallback& outer) : outer_(outer) {
    m_rayDirectionInverse = outer.m_rayDirectionInverse;
    m_signs[0] = outer.m_signs[0];
    m_signs[1] = outer.m_signs[1];
    m_signs[2] = outer.m_signs[2];
    m_lambda_max = outer.m_lambda_max;
  }
  bool process(const btBroadphaseProxy* node) override {
    return outer_.process(static_cast<const btBroadphaseProxy*>(node->m_clientObject));
  }

 private:
  btBroadphaseRayCallback& outer_;
};

class CcdQueryBroadphase::ForwardAabb final : public btBroadphaseAabbCallback {
 public:
  explicit ForwardAabb(btBroadphaseAabbCallback& outer) : outer_(outer) {}
  bool process(const btBroadphaseProxy* node) override {
    return outer_.process(static_cast<const btBroadphaseProxy*>(node->m_clientObject));
  }

 private:
  btBroadphaseAabbCallback& outer_;
};

CcdQueryBroadphase::CcdQueryBroadphase(std::unique_ptr<btBroadphaseInterface> pairs)
    : pairs_(std::move(pairs)) {
  tree_.m_deferedcollide = true;  // a tree only: never look for pairs
}

CcdQueryBroadphase::~CcdQueryBroadphase() = default;

btBroadphaseProxy* CcdQueryBroadphase::createProxy(const btVector3& aabbMin,
                                                   const btVector3& aabbMax, int shapeType,
                                                   void* userPtr, int collisionFilterGroup,
                                                   int collisionFilterMask,
                                                   btDispatcher* dispatcher) {
  btBroadphaseProxy* proxy = pairs_->createProxy(
      aabbMin, aabbMax, shapeType, userPtr, collisionFilterGroup, collisionFilterMask, dispatcher);
  if (proxy == nullptr) return nullptr;
  if (proxy->m_uniqueId < 0) {
    throw std::logic_error("CcdQueryBroadphase: a proxy numbered " +
                           std::to_string(proxy->m_uniqueId));
  }
  const auto id = static_cast<std::size_t>(proxy->m_uniqueId);
  try {
    if (id >= leaves_.size()) leaves_.resize(std::max(id + 1, 2 * leaves_.size()));
    if (leaves_[id].proxy != nullptr) {
      throw std::logic_error("CcdQueryBroadphase: two live proxies numbered " + std::to_string(id));
    }
    btBroadphaseProxy* node = tree_.createProxy(aabbMin, aabbMax, shapeType, proxy,
                                                collisionFilterGroup, collisionFilterMask, nullptr);
    leaves_[id] = Leaf{proxy, node, aabbMin, aabbMax, false, 0};
  } catch (...) {
    // No proxy is handed out: the pair search's goes too (out of memory in
    // the tree's insert, say), or it would outlive its object.
    pairs_->destroyProxy(proxy, dispatcher);
    throw;
  }
  return proxy;
}

CcdQueryBroadphase::Leaf& CcdQueryBroadphase::leafOf(const btBroadphaseProxy* proxy) {
  const auto id = static_cast<std::size_t>(proxy->m_uniqueId);
  if (proxy->m_uniqueId < 0 || id >= leaves_.size() || leaves_[id].proxy != proxy) {
    throw std::logic_error("CcdQueryBroadphase: a proxy it did not make, or one destroyed");
  }
  return leaves_[id];
}

void CcdQueryBroadphase::forgetProxy(btBroadphaseProxy* proxy) {
  if (proxy == nullptr) return;
  Leaf& leaf = leafOf(proxy);
  if (leaf.stale) stale_[leaf.stale_at] = -1;  // not erased: O(1) each
  tree_.destroyProxy(leaf.node, nullptr);
  leaf = Leaf{};
}

void CcdQueryBroadphase::destroyProxy(btBroadphaseProxy* proxy, btDispatcher* dispatcher) {
  forgetProxy(proxy);
  pairs_->destroyProxy(proxy, dispatcher);
}

void CcdQueryBroadphase::setAabb(btBroadphaseProxy* proxy, const btVector3& aabbMin,
                                 const btVector3& aabbMax, btDispatcher* dispatcher) {
  pairs_->setAabb(proxy, aabbMin, aabbMax, dispatcher);
  Leaf& leaf = leafOf(proxy);
  if (leaf.min == aabbMin && leaf.max == aabbMax) return;
  leaf.min = aabbMin;
  leaf.max = aabbMax;
  if (!leaf.stale) {
    leaf.stale_at = stale_.size();
    stale_.push_back(proxy->m_uniqueId);
  }
  leaf.stale = true;
  any_stale_.store(true, std::memory_order_relaxed);
}

void CcdQueryBroadphase::refreshForQueries() {
  if (!any_stale_.load(std::memory_order_acquire)) return;
  const std::lock_guard lock(refresh_mutex_);
  if (!any_stale_.load(std::memory_order_relaxed)) return;  // another query refreshed it
  for (const int id : stale_) {
    if (id < 0) continue;
    Leaf& leaf = leaves_[static_cast<std::size_t>(id)];
    tree_.setAabb(leaf.node, leaf.min, leaf.max, nullptr);
    leaf.stale = false;
  }
  stale_.clear();
  any_stale_.store(false, std::memory_order_release);
}

void CcdQueryBroadphase::getAabb(btBroadphaseProxy* proxy, btVector3& aabbMin,
                                 btVector3& aabbMax) const {
  pairs_->getAabb(proxy, aabbMin, aabbMax);
}

// btDbvtBroadphase::rayTest walks both of the tree's sets with one stack
// shared by every caller (without BT_THREADSAFE); the same walk, with a
// stack a call.  Not a thread_local one: glibc registers a thread_local's
// destructor at its first use in each thread, and aborts the process when
// that registration finds no memory (a worker's first CCD sweep under a
// tight ulimit -v); a stack a call is an allocation, which fails as
// std::bad_alloc.
void CcdQueryBroadphase::rayTest(const btVector3& rayFrom, const btVector3& rayTo,
                                 btBroadphaseRayCallback& callback, const btVector3& aabbMin,
                                 const btVector3& aabbMax) {
  const HostStopwatch watch;
  refreshForQueries();
  ForwardRay forward(callback);
  struct Visit final : btDbvt::ICollide {
    explicit Visit(ForwardRay& ray) : ray_(ray) {}
    void Process(const btDbvtNode* leaf) override {
      ray_.process(static_cast<const btBroadphaseProxy*>(leaf->data));
    }
    ForwardRay& ray_;
  } visit(forward);
  btAlignedObjectArray<const btDbvtNode*> stack;
  for (const btDbvt& set : tree_.m_sets) {
    set.rayTestInternal(set.m_root, rayFrom, rayTo, forward.m_rayDirectionInverse, forward.m_signs,
                        forward.m_lambda_max, aabbMin, aabbMax, stack, visit);
  }
  addQueryMs(watch.ms());
}

void CcdQueryBroadphase::aabbTest(const btVector3& aabbMin, const btVector3& aabbMax,
                                  btBroadphaseAabbCallback& callback) {
  const HostStopwatch watch;
  refreshForQueries();
  ForwardAabb forward(callback);
  tree_.aabbTest(aabbMin, aabbMax, forward);  // its walk's stack is its own
  addQueryMs(watch.ms());
}

void CcdQueryBroadphase::calculateOverlappingPairs(btDispatcher* dispatcher) {
  pairs_->calculateOverlappingPairs(dispatcher);
}

btOverlappingPairCache* CcdQueryBroadphase::getOverlappingPairCache() {
  return pairs_->getOverlappingPairCache();
}

const btOverlappingPairCache* CcdQueryBroadphase::getOverlappingPairCache() const {
  return pairs_->getOverlappingPairCache();
}

void CcdQueryBroadphase::getBroadphaseAabb(btVector3& aabbMin, btVector3& aabbMax) const {
  pairs_->getBroadphaseAabb(aabbMin, aabbMax);
}

void CcdQueryBroadphase::resetPool(btDispatcher* dispatcher) {
  pairs_->resetPool(dispatcher);
}

void CcdQueryBroadphase::printStats() {
  pairs_->printStats();
}

}  // namespace overlap::physics
