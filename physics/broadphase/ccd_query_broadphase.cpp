#include "physics/broadphase/ccd_query_broadphase.h"

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
  btBroadphaseProxy* node = tree_.createProxy(aabbMin, aabbMax, shapeType, proxy,
                                              collisionFilterGroup, collisionFilterMask, nullptr);
  leaves_.emplace(proxy, Leaf{node, aabbMin, aabbMax, false, 0});
  return proxy;
}

void CcdQueryBroadphase::forgetProxy(btBroadphaseProxy* proxy) {
  const auto found = leaves_.find(proxy);
  if (found == leaves_.end()) return;
  Leaf& leaf = found->second;
  if (leaf.stale) stale_[leaf.stale_at] = nullptr;  // not erased: O(1) each
  tree_.destroyProxy(leaf.node, nullptr);
  leaves_.erase(found);
}

void CcdQueryBroadphase::destroyProxy(btBroadphaseProxy* proxy, btDispatcher* dispatcher) {
  forgetProxy(proxy);
  pairs_->destroyProxy(proxy, dispatcher);
}

void CcdQueryBroadphase::setAabb(btBroadphaseProxy* proxy, const btVector3& aabbMin,
                                 const btVector3& aabbMax, btDispatcher* dispatcher) {
  pairs_->setAabb(proxy, aabbMin, aabbMax, dispatcher);
  Leaf& leaf = leaves_.at(proxy);
  if (leaf.min == aabbMin && leaf.max == aabbMax) return;
  leaf.min = aabbMin;
  leaf.max = aabbMax;
  if (!leaf.stale) {
    leaf.stale_at = stale_.size();
    stale_.push_back(&leaf);
  }
  leaf.stale = true;
}

void CcdQueryBroadphase::refresh() {
  for (Leaf* leaf : stale_) {
    if (leaf == nullptr) continue;
    tree_.setAabb(leaf->node, leaf->min, leaf->max, nullptr);
    leaf->stale = false;
  }
  stale_.clear();
}

void CcdQueryBroadphase::getAabb(btBroadphaseProxy* proxy, btVector3& aabbMin,
                                 btVector3& aabbMax) const {
  pairs_->getAabb(proxy, aabbMin, aabbMax);
}

void CcdQueryBroadphase::rayTest(const btVector3& rayFrom, const btVector3& rayTo,
                                 btBroadphaseRayCallback& callback, const btVector3& aabbMin,
                                 const btVector3& aabbMax) {
  const HostStopwatch watch;
  refresh();
  ForwardRay forward(callback);
  tree_.rayTest(rayFrom, rayTo, forward, aabbMin, aabbMax);
  query_ms_ += watch.ms();
}

void CcdQueryBroadphase::aabbTest(const btVector3& aabbMin, const btVector3& aabbMax,
                                  btBroadphaseAabbCallback& callback) {
  const HostStopwatch watch;
  refresh();
  ForwardAabb forward(callback);
  tree_.aabbTest(aabbMin, aabbMax, forward);
  query_ms_ += watch.ms();
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
