// PairFinderBroadphase: a Bullet broadphase backed by a gpu::PairFinder
// (cpubf, cpusap, gpubf or gpubf-paper), usable unchanged by any
// btCollisionWorld / btDiscreteDynamicsWorld.
//
// Each proxy owns a slot of the finder; its m_uniqueId is its slot index, so
// the same sequence of calls numbers proxies the same way on every run.  A
// search has two halves: launchPairSearch() hands the current boxes to the
// finder (which searches on its CUDA stream, or off this thread on the CPU),
// finishPairSearch() joins it and applies what changed to the owned
// btHashedOverlappingPairCache (removals through the dispatcher, which frees
// the pair's algorithm; a pair that stays keeps its cache entry untouched).
// calculateOverlappingPairs(), what Bullet's own step calls, does both at
// once; a caller with work to overlap with the search calls the two halves
// itself, with that work between them (TimedDynamicsWorld's substep calls
// them as two phases).  Either way lastSearch() says when the search ran and
// how long the caller waited.  Each launch also tells the finder which slots'
// boxes changed since the last one (a move buffer, as Box2D keeps), so that
// cpusap re-queries only the boxes that moved.  Where the finder has a
// staging area (gpubf's pinned memory, PairFinder::stagingFor), each search
// entry is written there as well when it changes, so a launch copies no boxes
// on the host.
//
// Invariants:
// - The cache holds exactly the pairs the finder last reported (minus those
//   its own overlap filter refused), each once.
// - The move buffer names every slot whose search entry differs from the last
//   launch's, each once; a write that leaves the entry as it was adds nothing.
// - Between a finish and the next launch, the finder's staging (if any) holds
//   every search entry of its first staging_.size() slots, unless
//   staging_stale_ says an entry was written while a search was in flight;
//   a launch rewrites all of it when slots were added or an entry went stale.
// - A destroyed proxy's pairs leave the cache at once; its slot is searched as
//   unused (group = mask = 0) by the next launch and reused only after the
//   finish that follows, so stale results for it are ignored, never applied
//   to a new proxy.
// - A proxy whose AABB is non-finite or inverted is out of the search (its
//   pairs are removed, one message on stderr) until it gets a valid AABB.
// - A launched search is always joined: by finishPairSearch(), or, on a path
//   that skips it (an exception), by the destructor.
// Like the rest of Bullet, it is not thread-safe: call it from one thread.
#pragma once

#include <btBulletCollisionCommon.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "gpu/pair_finder.h"
#include "physics/search_times.h"

namespace overlap::physics {

class PairFinderBroadphase final : public btBroadphaseInterface {
 public:
  explicit PairFinderBroadphase(std::unique_ptr<gpu::PairFinder> finder);
  ~PairFinderBroadphase() override;
  PairFinderBroadphase(const PairFinderBroadphase&) = delete;
  PairFinderBroadphase& operator=(const PairFinderBroadphase&) = delete;

  btBroadphaseProxy* createProxy(const btVector3& aabbMin, const btVector3& aabbMax, int shapeType,
                                 void* userPtr, int collisionFilterGroup, int collisionFilterMask,
                                 btDispatcher* dispatcher) override;
  void destroyProxy(btBroadphaseProxy* proxy, btDispatcher* dispatcher) override;
  void setAabb(btBroadphaseProxy* proxy, const btVector3& aabbMin, const btVector3& aabbMax,
               btDispatcher* dispatcher) override;
  void getAabb(btBroadphaseProxy* proxy, btVector3& aabbMin, btVector3& aabbMax) const override;
  void rayTest(const btVector3& rayFrom, const btVector3& rayTo,
               btBroadphaseRayCallback& rayCallback, const btVector3& aabbMin = btVector3(0, 0, 0),
               const btVector3& aabbMax = btVector3(0, 0, 0)) override;
  void aabbTest(const btVector3& aabbMin, const btVector3& aabbMax,
                btBroadphaseAabbCallback& callback) override;
  // launchPairSearch() then finishPairSearch(dispatcher).
  void calculateOverlappingPairs(btDispatcher* dispatcher) override;
  btOverlappingPairCache* getOverlappingPairCache() override { return pair_cache_.get(); }
  const btOverlappingPairCache* getOverlappingPairCache() const override {
    return pair_cache_.get();
  }
  // The union of the live, valid AABBs; all zero when there are none.
  void getBroadphaseAabb(btVector3& aabbMin, btVector3& aabbMax) const override;
  // With no live proxies, slots are handed out from 0 again.
  void resetPool(btDispatcher* dispatcher) override;
  void printStats() override;

  // The search's two halves, for a late join.  Starts the search over the
  // boxes as they are now; returns at once on the GPU.
  void launchPairSearch();
  // Waits for the search and brings the pair cache up to date.
  void finishPairSearch(btDispatcher* dispatcher);

  // The last finished search's times.
  const SearchTimes& lastSearch() const { return last_search_; }
  // The finder's split of its last search (cpusap's sort, sweep and delta).
  gpu::SearchPhases lastPhases() const { return finder_->lastPhases(); }
  // The finder's own launch() to finish() on the host clock, and its device
  // stages and host work (zero on the CPU finders).
  double lastLaunchToFinishMs() const { return finder_->lastLaunchToFinishMs(); }
  gpu::DeviceWork lastDeviceWork() const { return finder_->lastDeviceWork(); }
  bool searchInFlight() const { return search_in_flight_; }

 private:
  enum class SlotState : std::uint8_t {
    kLive,
    kDestroyed,  // waiting for a launch to search it as unused
    kDraining,   // searched as unused by the launch in flight; free at its finish
    kFree,
  };

  // The proxy's slot; throws unless it is a live proxy of this broadphase.
  std::uint32_t liveSlotOf(const btBroadphaseProxy* proxy, const char* caller) const;
  // Launches the finder over the search entries, through its staging when it
  // has one (bringing the staging up to date first).
  void launchFromStaging();
  // Writes the slot's search entry from its proxy, taking it out of the search
  // (with one message) when the AABB is unusable.
  void updateSearchEntry(std::uint32_t slot);
  void setSearchEntry(std::uint32_t slot, const gpu::ObjectBounds& entry);
  // Live proxies with a usable AABB, the ones queries may report.
  void forEachSearchableProxy(const std::function<void(btBroadphaseProxy&)>& visit);

  std::unique_ptr<gpu::PairFinder> finder_;
  std::unique_ptr<btHashedOverlappingPairCache> pair_cache_;
  // Indexed by slot.  A destroyed proxy stays allocated until its slot is
  // reused, so a stale result never names freed memory.
  std::vector<std::unique_ptr<btBroadphaseProxy>> proxies_;
  std::vector<SlotState> states_;
  std::vector<bool> aabb_valid_;
  std::vector<gpu::ObjectBounds> search_entries_;  // what the finder sees
  // The finder's staging as the last launch passed it; empty if it has none.
  std::span<gpu::ObjectBounds> staging_;
  bool staging_stale_ = false;  // an entry changed while the staging was not writable
  // The slots whose search entry changed since the last launch, each once
  // (changed_flags_ marks them): the finder's move buffer.
  std::vector<std::uint32_t> changed_slots_;
  std::vector<std::uint8_t> changed_flags_;
  std::vector<std::uint32_t> destroyed_;
  std::vector<std::uint32_t> draining_;
  std::vector<std::uint32_t> free_slots_;  // a stack: the last freed is reused first
  std::size_t live_count_ = 0;
  bool search_in_flight_ = false;
  SearchTimes last_search_;
};

}  // namespace overlap::physics
