// PairFinderBroadphase: a Bullet broadphase backed by a finders::PairFinder
// (any finder of gpu/pair_finder.h's table), usable unchanged by any
// btCollisionWorld / btDiscreteDynamicsWorld.
//
// Each proxy owns a slot of the finder; its m_uniqueId is its slot index, so
// the same sequence of calls numbers proxies the same way on every run.
// calculateOverlappingPairs() is one search: it hands the current boxes to
// the finder, waits for its answer and applies what changed to the owned
// pair cache in bulk (physics/broadphase/bulk_pair_cache.h: Bullet's hashed cache call
// for call, so the same pairs in the same order; removals through the
// dispatcher, which frees the pair's algorithm; a pair that stays keeps its
// cache entry untouched).
// Each search also tells the finder which slots' boxes changed since the
// last one (a move buffer, as Box2D keeps), so that cpusap re-queries only
// the boxes that moved.  Where the finder has a staging area (gpubf's pinned
// memory, PairFinder::stagingFor), each search entry is written there as
// well when it changes, so a search copies no boxes on the host.
//
// Invariants:
// - The cache holds exactly the pairs the finder last reported (minus those
//   its own overlap filter refused), each once.
// - The move buffer names every slot whose search entry differs from the last
//   search's, each once; a write that leaves the entry as it was adds nothing.
// - Between searches, the finder's staging (if any) holds every search entry
//   of its first staging_.size() slots; a search rewrites all of it when
//   slots were added since the last.
// - A destroyed proxy's pairs leave the cache at once; its slot is searched as
//   unused (group = mask = 0) by the next search and reused only after it, so
//   the finder never carries a destroyed proxy's pairs over to a new one.
// - A proxy whose AABB is not ordered (finders::pair_logic::boundsOrdered: a NaN,
//   or min > max on some axis) is out of the search (its pairs are removed,
//   one message on stderr) until it gets an ordered AABB.
// - beginSearch() and endSearch() split a search around other work: between
//   them the finder searches (a CPU finder as a job of the caller's group,
//   a GPU finder on its device) while the pair cache stays as it was and may
//   be read, and no other call may be made to the broadphase.
// Like the rest of Bullet, it is not thread-safe: call it from one thread
// (the search job of beginSearch() touches only the finder and the search
// entries, which nothing else touches until endSearch()).
#pragma once

#include <btBulletCollisionCommon.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "gpu/pair_finder.h"
#include "physics/broadphase/bulk_pair_cache.h"

namespace overlap::physics {

class PairFinderBroadphase final : public btBroadphaseInterface {
 public:
  // The most it holds for each proxy besides its finder's and its cache's
  // (the proxy, its state and box, its change marks; growth room included):
  // 167 to 170 bytes measured (tests/physics/broadphase_memory_test.cpp).
  static constexpr std::uint32_t kBytesPerSlot = 256;

  // on_device: the finder searches on a CUDA device, so its launch returns
  // at once and needs no thread of its own to search beside other work.
  explicit PairFinderBroadphase(std::unique_ptr<finders::PairFinder> finder,
                                bool on_device = false);
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
  // One search: the finder's answer for the boxes as they are now, applied
  // to the pair cache.
  void calculateOverlappingPairs(btDispatcher* dispatcher) override;
  // calculateOverlappingPairs() in two halves.  beginSearch() hands the
  // boxes to the finder and starts its search: a CPU finder's runs as a job
  // of `beside` (whose threads it shares with the caller's work), a GPU
  // finder's on its device.  endSearch() waits for it (rethrowing a search
  // job's error) and applies what changed to the pair cache.
  void beginSearch(TaskGroup& beside);
  void endSearch(btDispatcher* dispatcher);
  // The last endSearch()'s wait for the search, before the cache update.
  double lastSearchWaitMs() const { return last_search_wait_ms_; }
  btOverlappingPairCache* getOverlappingPairCache() override { return pair_cache_.get(); }
  const btOverlappingPairCache* getOverlappingPairCache() const override {
    return pair_cache_.get();
  }
  // The union of the live, valid AABBs; all zero when there are none.
  void getBroadphaseAabb(btVector3& aabbMin, btVector3& aabbMax) const override;
  // With no live proxies, slots are handed out from 0 again.
  void resetPool(btDispatcher* dispatcher) override;
  void printStats() override;

  // The finder's record of its last search (finders::PairFinder::lastStats).
  finders::SearchStats lastSearchStats() const { return finder_->lastStats(); }
  // The last search's time applying the finder's changes to the pair cache.
  double lastCacheUpdateMs() const { return last_cache_update_ms_; }

 private:
  enum class SlotState : std::uint8_t {
    kLive,
    kDestroyed,  // waiting for a search to see it unused; free after that search
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
  void setSearchEntry(std::uint32_t slot, const finders::ObjectBounds& entry);
  // Live proxies with a usable AABB, the ones queries may report.
  void forEachSearchableProxy(const std::function<void(btBroadphaseProxy&)>& visit);

  // endSearch() and calculateOverlappingPairs()'s second half.
  void applySearch(btDispatcher* dispatcher);

  std::unique_ptr<finders::PairFinder> finder_;
  bool on_device_;
  TaskGroup* searching_ = nullptr;  // between beginSearch() and endSearch()
  std::unique_ptr<BulkPairCache> pair_cache_;
  // Indexed by slot.  A destroyed proxy stays allocated until its slot is
  // reused, so a stale result never names freed memory.
  std::vector<std::unique_ptr<btBroadphaseProxy>> proxies_;
  std::vector<SlotState> states_;
  // Indexed by slot: the live proxy, null where the slot is not live (what
  // the cache skips in a search's changes).
  std::vector<btBroadphaseProxy*> live_proxies_;
  std::vector<bool> aabb_valid_;
  std::vector<finders::ObjectBounds> search_entries_;  // what the finder sees
  // The finder's staging as the last search passed it; empty if it has none.
  std::span<finders::ObjectBounds> staging_;
  // The slots whose search entry changed since the last search, each once
  // (changed_flags_ marks them): the finder's move buffer.
  std::vector<std::uint32_t> changed_slots_;
  std::vector<std::uint8_t> changed_flags_;
  std::vector<std::uint32_t> destroyed_;
  std::vector<std::uint32_t> free_slots_;  // a stack: the last freed is reused first
  std::size_t live_count_ = 0;
  double last_cache_update_ms_ = 0;
  double last_search_wait_ms_ = 0;
};

}  // namespace overlap::physics
