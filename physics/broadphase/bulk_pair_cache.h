// BulkPairCache: Bullet's btOverlappingPairCache for our pair finders, taking
// a search's sorted added and removed pairs in bulk.
//
// Call for call it behaves as Bullet's btHashedOverlappingPairCache, so any
// dispatcher, world or ghost object uses it unchanged and sees the same pairs
// in the same order: a pair is held once with m_pProxy0 the lower
// m_uniqueId; an added pair is appended (the ghost callback hears it); a
// removed pair frees its algorithm through the dispatcher, the ghost callback
// hears it, and the array's last pair takes its place; the overlap filter
// (or the group/mask test) decides what is added; processAllOverlappingPairs
// visits in array order, or by descending ids when dispatchInfo asks for
// deterministic pairs; sortOverlappingPairs re-adds every pair in Bullet's
// sorted order.
//
// What differs is the index from a pair to its place in the array: an
// open-addressing hash of the pair's two ids (one cache line per lookup in
// the common case, where Bullet's chains read the pair and both proxies), and
// applyChanges(), which applies a search's removals and then its additions
// exactly as removeOverlappingPair and addOverlappingPair would, one by one
// in the lists' order, with each lookup fetched some pairs ahead.
//
// Memory: the cache allocates its pair array itself (Bullet's array does not
// check its allocations), so running out throws std::bad_alloc, never a null
// write.  With a memory limit, a growth past it is refused before anything
// is allocated: applyChanges() throws PairMemoryError, naming the pairs and
// the bytes they need; addOverlappingPair(), which Bullet's own broadphases
// call from inside theirs, returns null instead (as for a filtered pair,
// which they take as not added) and keeps the refusal for throwIfRefused(),
// since an exception unwinding through Bullet leaves its state half-made (a
// proxy created but not yet returned, never freed).  Once refused, it adds
// no pair.
//
// Invariants:
// - keys_[i] is the key of pairs_[i] (lower id in the high half), and the
//   index maps each of those keys to i and holds nothing else.
// - The index has at least twice as many slots as pairs (a power of two).
// - bytesHeld() is at most the memory limit, when there is one.
// Like the rest of Bullet, it is not thread-safe.
#pragma once

#include <btBulletCollisionCommon.h>

#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <vector>

#include "gpu/pair_finder.h"

namespace overlap::physics {

// A cache that would grow past its memory limit: how many pairs it was to
// hold, what they need, and the limit.  With `more_than`, a finder stopped
// counting at `pairs` (the most the limit could hold): the frame has more,
// and needs more than `bytes`.
class PairMemoryError : public std::runtime_error {
 public:
  PairMemoryError(std::uint64_t pairs, std::uint64_t bytes, std::uint64_t limit,
                  bool more_than = false);
  std::uint64_t pairs, bytes, limit;
  bool more_than;
};

// Memory for the cache's big arrays: 2 MiB aligned and marked for huge pages
// above 2 MiB, as their lookups land anywhere in them (fewer TLB misses).
// Through the aligned operator new, so that a replaced one counts it; freed
// with the size it was allocated with (which chose its alignment).
void* allocateLookupMemory(std::size_t bytes);
void freeLookupMemory(void* memory, std::size_t bytes) noexcept;

template <class T>
struct LookupAllocator {
  using value_type = T;
  LookupAllocator() = default;
  template <class U>
  LookupAllocator(const LookupAllocator<U>& /*other*/) {}
  T* allocate(std::size_t count) {
    return static_cast<T*>(allocateLookupMemory(count * sizeof(T)));
  }
  void deallocate(T* memory, std::size_t count) noexcept {
    freeLookupMemory(memory, count * sizeof(T));
  }
  friend bool operator==(const LookupAllocator&, const LookupAllocator&) = default;
};

class BulkPairCache final : public btOverlappingPairCache {
 public:
  BulkPairCache();
  ~BulkPairCache() override;
  BulkPairCache(const BulkPairCache&) = delete;
  BulkPairCache& operator=(const BulkPairCache&) = delete;

  // A search's changes: removeOverlappingPair for each pair of `removed`,
  // then addOverlappingPair for each of `added`, in the lists' order, as if
  // called one by one.  `proxies[i]` is the proxy whose m_uniqueId is i, or
  // null where slot i's pairs are to be skipped (its proxy is gone); every
  // pair's slots index `proxies`.
  void applyChanges(std::span<const finders::IndexPair> removed,
                    std::span<const finders::IndexPair> added,
                    std::span<btBroadphaseProxy* const> proxies, btDispatcher* dispatcher);

  // The most bytes the cache may hold, 0 for no limit; `elsewhere_per_pair`
  // bytes a pair costs outside the cache (the finder's own pair lists) count
  // against it too.
  void setMemoryLimit(std::uint64_t bytes, std::uint64_t elsewhere_per_pair = 0) {
    memory_limit_ = bytes;
    elsewhere_per_pair_ = elsewhere_per_pair;
  }
  // The pair array, keys and index as allocated.
  std::uint64_t bytesHeld() const;
  // The most pairs the limit could ever hold, 0 without a limit: a pair
  // finder's limit (finders::PairFinder::setPairLimit), so that a frame the
  // cache would refuse stops the finder before its lists grow for it.
  std::uint64_t mostPairs() const;
  // Throws the PairMemoryError of a frame with more than `most_pairs` pairs,
  // a finder's refusal (finders::PairLimitError).
  [[noreturn]] void refuseMoreThan(std::uint64_t most_pairs) const;
  // Throws the PairMemoryError of the first pair addOverlappingPair() refused
  // under the memory limit, if any.  Call it after each call into Bullet.
  void throwIfRefused() const {
    if (refusal_) throw *refusal_;
  }

  // btOverlappingPairCallback
  btBroadphasePair* addOverlappingPair(btBroadphaseProxy* proxy0,
                                       btBroadphaseProxy* proxy1) override;
  void* removeOverlappingPair(btBroadphaseProxy* proxy0, btBroadphaseProxy* proxy1,
                              btDispatcher* dispatcher) override;
  void removeOverlappingPairsContainingProxy(btBroadphaseProxy* proxy,
                                             btDispatcher* dispatcher) override;

  // btOverlappingPairCache
  btBroadphasePair* getOverlappingPairArrayPtr() override { return &pairs_[0]; }
  const btBroadphasePair* getOverlappingPairArrayPtr() const override { return &pairs_[0]; }
  btBroadphasePairArray& getOverlappingPairArray() override { return pairs_; }
  void cleanOverlappingPair(btBroadphasePair& pair, btDispatcher* dispatcher) override;
  int getNumOverlappingPairs() const override { return pairs_.size(); }
  bool needsBroadphaseCollision(btBroadphaseProxy* proxy0,
                                btBroadphaseProxy* proxy1) const override;
  btOverlapFilterCallback* getOverlapFilterCallback() override { return filter_; }
  void cleanProxyFromPairs(btBroadphaseProxy* proxy, btDispatcher* dispatcher) override;
  void setOverlapFilterCallback(btOverlapFilterCallback* callback) override { filter_ = callback; }
  void processAllOverlappingPairs(btOverlapCallback* callback, btDispatcher* dispatcher) override;
  void processAllOverlappingPairs(btOverlapCallback* callback, btDispatcher* dispatcher,
                                  const btDispatcherInfo& dispatchInfo) override;
  btBroadphasePair* findPair(btBroadphaseProxy* proxy0, btBroadphaseProxy* proxy1) override;
  bool hasDeferredRemoval() override { return false; }
  void setInternalGhostPairCallback(btOverlappingPairCallback* ghostPairCallback) override {
    ghost_ = ghostPairCallback;
  }
  void sortOverlappingPairs(btDispatcher* dispatcher) override;

  // Visits pairs_[i] for each i of `indices` (each once), in the order the
  // visit above would take them: Bullet's deterministic order, or the
  // array's.  So a pass that has work for a few pairs only (a narrowphase
  // whose other pairs already ran) sorts those few, not the cache.  The
  // callback may not remove a pair (it would move the others): asking to
  // throws std::logic_error.
  void processPairsInVisitOrder(std::span<const int> indices, btOverlapCallback* callback,
                                const btDispatcherInfo& dispatchInfo);

 private:
  struct Visit {
    std::uint64_t key;  // (id0, id1) as Bullet compares them, signed
    int index;
  };
  struct IndexSlot {
    std::uint64_t key;
    std::uint32_t pair;  // its place in pairs_
    std::uint32_t unused;
  };
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  // no pair of two ids -1

  // The index slot holding `key`, or the empty slot where it would go.
  std::size_t slotOf(std::uint64_t key) const;
  std::size_t home(std::uint64_t key) const;
  void prefetchSlot(std::uint64_t key) const;
  // Makes room for `pairs` pairs (array and index), within the limit.
  void reserve(std::size_t pairs);
  std::uint64_t bytesFor(std::size_t capacity, std::size_t index_slots) const;
  // A pair's bytes but its index slots: its entry, its key, and elsewhere's.
  std::uint64_t bytesPerPair() const {
    return sizeof(btBroadphasePair) + sizeof(std::uint64_t) + elsewhere_per_pair_;
  }
  void growPairs(std::size_t capacity);
  void rehash(std::size_t index_slots);
  void eraseSlot(std::size_t slot);
  Visit visitOf(int index) const;
  static void sortForVisit(std::vector<Visit>& visits);
  // Bullet's internalAddPair and removeOverlappingPair, ids already ordered.
  btBroadphasePair* addOrdered(btBroadphaseProxy* low, btBroadphaseProxy* high);
  void* removeOrdered(btBroadphaseProxy* low, btBroadphaseProxy* high, btDispatcher* dispatcher);
  void* removeKey(std::uint64_t key, btBroadphaseProxy* low, btBroadphaseProxy* high,
                  btDispatcher* dispatcher);

  btBroadphasePairArray pairs_;  // on owned_'s memory
  btBroadphasePair* owned_ = nullptr;
  std::size_t owned_capacity_ = 0;  // pairs owned_ holds room for
  std::vector<std::uint64_t, LookupAllocator<std::uint64_t>> keys_;
  std::vector<IndexSlot, LookupAllocator<IndexSlot>> index_;
  int index_shift_ = 64;  // 64 - log2(index_.size())
  btOverlapFilterCallback* filter_ = nullptr;
  btOverlappingPairCallback* ghost_ = nullptr;
  std::uint64_t memory_limit_ = 0;
  std::uint64_t elsewhere_per_pair_ = 0;
  std::optional<PairMemoryError> refusal_;  // the first pair refused, if any
  std::vector<Visit> visits_;               // processPairsInVisitOrder's, kept for its capacity
};

}  // namespace overlap::physics
