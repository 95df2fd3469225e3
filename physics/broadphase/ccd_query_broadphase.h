// A broadphase whose ray and sweep queries go through one tree shared by
// every broadphase: the pairs come from the broadphase asked for, the
// queries from Bullet's dynamic AABB tree (btDbvtBroadphase, used as a tree
// only: no pairs of its own).
//
// Why: Bullet's CCD (its predictive contacts and the motion clamp) sweeps
// each fast body through rayTest.  btSimpleBroadphase answers that by
// visiting every proxy, btAxisSweep3 through an optional tree of its own,
// btDbvtBroadphase through its tree and ours by a scan, so with CCD on a
// run's time measured the query path as much as the pair search.  With one
// query tree for all, every broadphase meets the same queries in the same
// order (the same physics), and the queries' time is a column of its own.
//
// Invariants: every call but rayTest and aabbTest goes to the wrapped
// broadphase unchanged, with its own proxies (what the world holds); the
// tree holds one leaf per proxy, kept by the proxy's m_uniqueId in a vector
// (every Bullet broadphase and ours number their live proxies apart) and
// refreshed from the latest setAabb at the first query after it (a run
// without CCD never builds it); a query visits proxies of the wrapped
// broadphase, in an order fixed by the calls alone.
// Threads: rayTest and aabbTest may run on several threads at once (CCD's
// sweeps on the task system), between calls of the rest, which take one
// thread: the first query after a setAabb refreshes the tree under a lock,
// and each thread walks it with a stack of its own; refreshForQueries() may
// run the refresh early, beside other work.
#pragma once

#include <BulletCollision/BroadphaseCollision/btDbvtBroadphase.h>
#include <btBulletCollisionCommon.h>

#include <atomic>
#include <memory>
#include <mutex>
#include <vector>

namespace overlap::physics {

class CcdQueryBroadphase final : public btBroadphaseInterface {
 public:
  explicit CcdQueryBroadphase(std::unique_ptr<btBroadphaseInterface> pairs);
  ~CcdQueryBroadphase() override;

  // The broadphase that finds the pairs.
  btBroadphaseInterface& pairSearch() { return *pairs_; }
  // Drops the tree's leaf of `proxy` (nullptr: nothing) and leaves the
  // wrapped proxy itself to its broadphase's destructor, for a teardown of a
  // broadphase that frees its proxies whole (isSweepAndPrune()).
  void forgetProxy(btBroadphaseProxy* proxy);
  // Time spent in rayTest and aabbTest (tree refresh included) since construction, ms.
  // Queries on several threads at once add up each one's time.
  double queryMs() const { return query_ms_.load(std::memory_order_relaxed); }
  // Brings every stale leaf into the tree, in the order setAabb saw them,
  // once for all the queries that follow (the first query after a setAabb
  // does it itself when nothing did).  Its time is not in queryMs().  It may
  // run on another thread beside the world's other work, while no call but
  // rayTest and aabbTest is made: the world's solver, which makes none.
  void refreshForQueries();

  btBroadphaseProxy* createProxy(const btVector3& aabbMin, const btVector3& aabbMax, int shapeType,
                                 void* userPtr, int collisionFilterGroup, int collisionFilterMask,
                                 btDispatcher* dispatcher) override;
  void destroyProxy(btBroadphaseProxy* proxy, btDispatcher* dispatcher) override;
  void setAabb(btBroadphaseProxy* proxy, const btVector3& aabbMin, const btVector3& aabbMax,
               btDispatcher* dispatcher) override;
  void getAabb(btBroadphaseProxy* proxy, btVector3& aabbMin, btVector3& aabbMax) const override;
  void rayTest(const btVector3& rayFrom, const btVector3& rayTo, btBroadphaseRayCallback& callback,
               const btVector3& aabbMin, const btVector3& aabbMax) override;
  void aabbTest(const btVector3& aabbMin, const btVector3& aabbMax,
                btBroadphaseAabbCallback& callback) override;
  void calculateOverlappingPairs(btDispatcher* dispatcher) override;
  btOverlappingPairCache* getOverlappingPairCache() override;
  const btOverlappingPairCache* getOverlappingPairCache() const override;
  void getBroadphaseAabb(btVector3& aabbMin, btVector3& aabbMax) const override;
  void resetPool(btDispatcher* dispatcher) override;
  void printStats() override;

 private:
  struct Leaf {
    const btBroadphaseProxy* proxy = nullptr;  // the wrapped one; null: no leaf
    btBroadphaseProxy* node = nullptr;  // the tree's, whose client object is the wrapped proxy
    btVector3 min, max;                 // the latest setAabb
    bool stale = false;                 // min/max not yet in the tree (then it is in stale_)
    std::size_t stale_at = 0;           // its place in stale_, when stale
  };
  // The proxy's leaf; throws std::logic_error for a proxy without one.
  Leaf& leafOf(const btBroadphaseProxy* proxy);
  void addQueryMs(double ms) { query_ms_.fetch_add(ms, std::memory_order_relaxed); }
  // Passes the tree's answers on as the wrapped broadphase's proxies.
  class ForwardRay;
  class ForwardAabb;

  std::unique_ptr<btBroadphaseInterface> pairs_;
  btNullPairCache no_pairs_;
  btDbvtBroadphase tree_{&no_pairs_};
  std::vector<Leaf> leaves_;  // by the wrapped proxy's m_uniqueId
  // In setAabb order, by m_uniqueId; -1 where a leaf was since destroyed.
  std::vector<int> stale_;
  std::atomic<bool> any_stale_{false};
  std::mutex refresh_mutex_;
  std::atomic<double> query_ms_{0};
};

}  // namespace overlap::physics
