// ParallelDispatcher: Bullet's btCollisionDispatcher with the narrowphase's
// contact generation spread over a task system (gpu/task_system.h), and the
// contacts bit for bit those of Bullet's serial dispatch, in the same order.
//
// Bullet's dispatch visits the cached pairs in the cache's order and, for
// each, finds its collision algorithm (allocating it and its manifold from
// the dispatcher's pools) when it has none, then runs the algorithm's
// processCollision.  Here that visit is one serial pass in the same order:
// finding algorithms, and running every algorithm that is not
// btBoxBoxCollisionAlgorithm as Bullet would, in place.  The box-box pairs'
// processCollision calls are collected and then run in parallel.
//
// Which Bullet calls run off the main thread, and why each is safe:
// - btBoxBoxCollisionAlgorithm::processCollision, one pair a call.  It
//   reads the two bodies' shapes and world transforms, which nothing writes
//   during the narrowphase, and writes only its own persistent manifold
//   (points added through a btManifoldResult on the caller's stack, then
//   refreshed).  Its manifold was made with the algorithm, in the serial
//   pass.
// - Inside it, btPersistentManifold::addManifoldPoint/removeContactPoint call
//   Bullet's global contact callbacks when they are set, and those may do
//   anything: with any of gContactAddedCallback, gContactProcessedCallback,
//   gContactDestroyedCallback, gContactStartedCallback or
//   gContactEndedCallback set, everything runs serially.
// Nothing else runs off the main thread: every pool allocation, algorithm
// lookup, manifold creation and release stays in the serial pass, in pair
// order, so the dispatcher's manifold array (whose releases swap the last
// manifold into the freed slot) is the serial dispatch's.
//
// Serial only, exactly Bullet's btCollisionDispatcher::dispatchAllCollisionPairs:
// a task system of one thread, a custom near callback, a continuous
// (time-of-impact) dispatch, a global contact callback, or setParallel(false).
//
// The split for a search beside the narrowphase (TimedDynamicsWorld):
// dispatchStayingPairs() runs, while the pair search runs, the box-box
// pairs already in the cache with an algorithm; after the search has
// changed the cache, dispatchRemainingPairs() runs the serial pass over the
// cache as it now is, skipping the box-box pairs that came with an
// algorithm (the first half ran them: the search adds pairs without one),
// and then the new box-box pairs in parallel.  Each pair's processCollision
// runs once, on the same transforms; algorithm creations and the lost
// pairs' releases happen in the serial order, so the state is the same.
//
// With our pair cache (BulkPairCache), the serial pass visits in the
// cache's order only the pairs that have serial work (no algorithm yet, or
// not box-box), so it sorts those few, not every pair: the box-box pairs
// with an algorithm touch nothing shared, and in what order they are
// collected cannot matter.
//
// Like the rest of Bullet, call it from one thread.
#pragma once

#include <btBulletCollisionCommon.h>

#include <vector>

#include "gpu/task_system.h"

namespace overlap::physics {

class ParallelDispatcher final : public btCollisionDispatcher {
 public:
  // `tasks` must outlive the dispatcher.
  ParallelDispatcher(btCollisionConfiguration* config, TaskSystem& tasks);

  // false: every dispatch is Bullet's serial one.
  void setParallel(bool parallel) { parallel_ = parallel; }
  // Whether a dispatch with `info` runs its box-box pairs in parallel now.
  bool dispatchesInParallel(const btDispatcherInfo& info) const;

  void dispatchAllCollisionPairs(btOverlappingPairCache* cache, const btDispatcherInfo& info,
                                 btDispatcher* dispatcher) override;
  // The two halves of a dispatch around a search that changes the cache;
  // only when dispatchesInParallel(info).
  void dispatchStayingPairs(btOverlappingPairCache* cache, const btDispatcherInfo& info);
  void dispatchRemainingPairs(btOverlappingPairCache* cache, const btDispatcherInfo& info);

  // Box-box pairs the last dispatch ran in parallel, both halves together.
  int lastParallelPairs() const { return last_parallel_pairs_; }

 private:
  class SerialPass;
  void processInParallel(const btDispatcherInfo& info);

  TaskSystem& tasks_;
  bool parallel_ = true;
  std::vector<btBroadphasePair*> box_pairs_;  // this half's
  std::vector<int> serial_pairs_;             // the pairs with serial work, by array index
  bool staying_ran_ = false;                  // dispatchStayingPairs ran, the rest has not
  int last_parallel_pairs_ = 0;
};

}  // namespace overlap::physics
