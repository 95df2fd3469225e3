#include "physics/broadphase/bulk_pair_cache.h"

#include <sys/mman.h>

#include <algorithm>
#include <bit>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <string>

namespace overlap::physics {
namespace {

// How many pairs ahead applyChanges() fetches the index slots it will read.
constexpr std::size_t kAhead = 32;
constexpr std::size_t kSmallestIndex = 16;

// The key of the pair of ids `low` <= `high` (Bullet's order: by m_uniqueId).
std::uint64_t orderedKey(int low, int high) {
  return (std::uint64_t{static_cast<std::uint32_t>(low)} << 32) | static_cast<std::uint32_t>(high);
}

std::uint64_t keyOf(const finders::IndexPair& pair) {
  return (std::uint64_t{pair.a} << 32) | pair.b;
}

void prefetch(const void* address) {
  __builtin_prefetch(address);
}

constexpr std::size_t kHugePage = std::size_t{2} << 20;

std::align_val_t lookupAlignment(std::size_t bytes) {
  return std::align_val_t{bytes >= kHugePage ? kHugePage : 64};
}

}  // namespace

void* allocateLookupMemory(std::size_t bytes) {
  bytes = std::max<std::size_t>(bytes, 1);
  void* memory = ::operator new(bytes, lookupAlignment(bytes));
  // A hint: without huge pages the lookups only run slower.
  if (bytes >= kHugePage) ::madvise(memory, bytes, MADV_HUGEPAGE);
  return memory;
}

void freeLookupMemory(void* memory, std::size_t bytes) noexcept {
  ::operator delete(memory, lookupAlignment(std::max<std::size_t>(bytes, 1)));
}

PairMemoryError::PairMemoryError(std::uint64_t pair_count, std::uint64_t needed, std::uint64_t most,
                                 bool at_least)
    : std::runtime_error(std::string(at_least ? "more than " : "") + std::to_string(pair_count) +
                         " pairs need " + (at_least ? "more than " : "") + std::to_string(needed) +
                         " bytes, above the pair memory limit of " + std::to_string(most) +
                         " bytes"),
      pairs(pair_count),
      bytes(needed),
      limit(most),
      more_than(at_least) {}

BulkPairCache::BulkPairCache() {
  index_.assign(kSmallestIndex, IndexSlot{kEmpty, 0, 0});
  index_shift_ = 64 - std::countr_zero(kSmallestIndex);
}

BulkPairCache::~BulkPairCache() {
  pairs_.initializeFromBuffer(nullptr, 0, 0);
  freeLookupMemory(owned_, owned_capacity_ * sizeof(btBroadphasePair));
}

std::uint64_t BulkPairCache::bytesFor(std::size_t capacity, std::size_t index_slots) const {
  return std::uint64_t{capacity} * bytesPerPair() + std::uint64_t{index_slots} * sizeof(IndexSlot);
}

std::uint64_t BulkPairCache::mostPairs() const {
  if (memory_limit_ == 0) return 0;
  return std::max<std::uint64_t>(1, memory_limit_ / bytesPerPair());
}

void BulkPairCache::refuseMoreThan(std::uint64_t most_pairs) const {
  const std::size_t pairs = static_cast<std::size_t>(most_pairs);
  throw PairMemoryError(most_pairs,
                        bytesFor(pairs, std::bit_ceil(std::max(2 * pairs, kSmallestIndex))),
                        memory_limit_, true);
}

std::uint64_t BulkPairCache::bytesHeld() const {
  return std::uint64_t{static_cast<std::size_t>(pairs_.capacity())} * sizeof(btBroadphasePair) +
         keys_.capacity() * sizeof(std::uint64_t) + index_.size() * sizeof(IndexSlot);
}

// Doubles the array as Bullet's does where the limit allows, else takes all
// the limit leaves (so that growing one pair at a time stays linear);
// refuses what the limit cannot hold, the old arrays held while growing
// counted.
void BulkPairCache::reserve(std::size_t pairs) {
  const auto held = static_cast<std::size_t>(pairs_.capacity());
  if (pairs <= held && index_.size() >= 2 * pairs) return;
  const std::size_t index_slots = index_.size() >= 2 * pairs
                                      ? index_.size()
                                      : std::bit_ceil(std::max(2 * pairs, kSmallestIndex));
  // Powers of two, as Bullet's array grows from 2 by doubling.
  std::size_t capacity = pairs <= held ? held : std::max(std::bit_ceil(pairs), 2 * held);
  // While an array grows its old one is held beside it: the pair array's
  // while the pairs are copied, then the index's while it is rebuilt.
  const std::uint64_t old_arrays =
      (pairs > held ? std::uint64_t{held} * sizeof(btBroadphasePair) : 0) +
      (index_slots > index_.size() ? index_.size() * sizeof(IndexSlot) : 0);
  if (memory_limit_ != 0 && bytesFor(capacity, index_slots) + old_arrays > memory_limit_) {
    const std::uint64_t besides_pairs = std::uint64_t{index_slots} * sizeof(IndexSlot) + old_arrays;
    const std::uint64_t fits =
        memory_limit_ > besides_pairs ? (memory_limit_ - besides_pairs) / bytesPerPair() : 0;
    if (fits < pairs) {
      throw PairMemoryError(
          pairs, bytesFor(pairs, std::bit_ceil(std::max(2 * pairs, kSmallestIndex))) + old_arrays,
          memory_limit_);
    }
    capacity = std::max(held, static_cast<std::size_t>(std::min<std::uint64_t>(fits, capacity)));
  }
  if (capacity > held) growPairs(capacity);
  if (index_slots > index_.size()) rehash(index_slots);
}

// The array on memory of our own: Bullet's array would write through a
// failed allocation.
void BulkPairCache::growPairs(std::size_t capacity) {
  if (capacity > static_cast<std::size_t>(std::numeric_limits<int>::max())) throw std::bad_alloc();
  keys_.reserve(capacity);  // first: nothing after it throws
  auto* fresh =
      static_cast<btBroadphasePair*>(allocateLookupMemory(capacity * sizeof(btBroadphasePair)));
  const int size = pairs_.size();
  if (size > 0) {
    std::memcpy(fresh, &pairs_[0], sizeof(btBroadphasePair) * static_cast<std::size_t>(size));
  }
  pairs_.initializeFromBuffer(fresh, size, static_cast<int>(capacity));
  freeLookupMemory(owned_, owned_capacity_ * sizeof(btBroadphasePair));
  owned_ = fresh;
  owned_capacity_ = capacity;
}

std::size_t BulkPairCache::home(std::uint64_t key) const {
  return static_cast<std::size_t>((key * 0x9e3779b97f4a7c15ULL) >> index_shift_);
}

std::size_t BulkPairCache::slotOf(std::uint64_t key) const {
  const std::size_t mask = index_.size() - 1;
  std::size_t slot = home(key);
  while (index_[slot].key != key && index_[slot].key != kEmpty) slot = (slot + 1) & mask;
  return slot;
}

void BulkPairCache::prefetchSlot(std::uint64_t key) const {
  prefetch(&index_[home(key)]);
}

void BulkPairCache::rehash(std::size_t index_slots) {
  decltype(index_) fresh(index_slots, IndexSlot{kEmpty, 0, 0});
  index_.swap(fresh);
  index_shift_ = 64 - std::countr_zero(index_slots);
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    index_[slotOf(keys_[i])] = IndexSlot{keys_[i], static_cast<std::uint32_t>(i), 0};
  }
}

// Linear probing's deletion: later entries of the run move back into the
// hole wherever their home allows, so no lookup ever stops short.
void BulkPairCache::eraseSlot(std::size_t slot) {
  const std::size_t mask = index_.size() - 1;
  std::size_t hole = slot;
  for (std::size_t i = (slot + 1) & mask; index_[i].key != kEmpty; i = (i + 1) & mask) {
    if (((i - home(index_[i].key)) & mask) >= ((i - hole) & mask)) {
      index_[hole] = index_[i];
      hole = i;
    }
  }
  index_[hole].key = kEmpty;
}

btBroadphasePair* BulkPairCache::addOrdered(btBroadphaseProxy* low, btBroadphaseProxy* high) {
  const std::uint64_t key = orderedKey(low->m_uniqueId, high->m_uniqueId);
  std::size_t slot = slotOf(key);
  if (index_[slot].key == key) return &pairs_[static_cast<int>(index_[slot].pair)];
  if (pairs_.size() == pairs_.capacity() || index_.size() < 2 * keys_.size() + 2) {
    reserve(static_cast<std::size_t>(pairs_.size()) + 1);
    slot = slotOf(key);
  }
  const int count = pairs_.size();
  void* memory = &pairs_.expandNonInitializing();
  if (ghost_ != nullptr) ghost_->addOverlappingPair(low, high);
  auto* pair = new (memory) btBroadphasePair(*low, *high);
  pair->m_algorithm = nullptr;
  pair->m_internalTmpValue = 0;
  keys_.push_back(key);
  index_[slot] = IndexSlot{key, static_cast<std::uint32_t>(count), 0};
  return pair;
}

void* BulkPairCache::removeOrdered(btBroadphaseProxy* low, btBroadphaseProxy* high,
                                   btDispatcher* dispatcher) {
  return removeKey(orderedKey(low->m_uniqueId, high->m_uniqueId), low, high, dispatcher);
}

void* BulkPairCache::removeKey(std::uint64_t key, btBroadphaseProxy* low, btBroadphaseProxy* high,
                               btDispatcher* dispatcher) {
  const std::size_t slot = slotOf(key);
  if (index_[slot].key == kEmpty) return nullptr;
  const int at = static_cast<int>(index_[slot].pair);
  btBroadphasePair& pair = pairs_[at];
  cleanOverlappingPair(pair, dispatcher);
  void* user_data = pair.m_internalInfo1;
  eraseSlot(slot);
  const int last = pairs_.size() - 1;
  if (ghost_ != nullptr) ghost_->removeOverlappingPair(low, high, dispatcher);
  if (at != last) {  // the last pair takes the removed one's place
    const std::uint64_t moved = keys_[static_cast<std::size_t>(last)];
    index_[slotOf(moved)].pair = static_cast<std::uint32_t>(at);
    pairs_[at] = pairs_[last];
    keys_[static_cast<std::size_t>(at)] = moved;
  }
  pairs_.pop_back();
  keys_.pop_back();
  return user_data;
}

void BulkPairCache::applyChanges(std::span<const finders::IndexPair> removed,
                                 std::span<const finders::IndexPair> added,
                                 std::span<btBroadphaseProxy* const> proxies,
                                 btDispatcher* dispatcher) {
  // Removals: a slot is fetched kAhead pairs ahead; halfway there its pair
  // (and the slot of the last pair, which will move) is fetched too.
  for (std::size_t i = 0; i < removed.size(); ++i) {
    if (i + kAhead < removed.size()) {
      prefetchSlot(keyOf(removed[i + kAhead]));
      prefetch(&proxies[removed[i + kAhead].b]);
    }
    if (i + kAhead / 2 < removed.size()) {
      const IndexSlot& ahead = index_[slotOf(keyOf(removed[i + kAhead / 2]))];
      if (ahead.key != kEmpty) prefetch(&pairs_[static_cast<int>(ahead.pair)]);
      const std::size_t pairs = keys_.size();
      if (pairs > kAhead) prefetchSlot(keys_[pairs - 1 - kAhead]);
    }
    btBroadphaseProxy* low = proxies[removed[i].a];
    btBroadphaseProxy* high = proxies[removed[i].b];
    // The key from the slots (= ids), so no proxy is read.
    if (low != nullptr && high != nullptr) removeKey(keyOf(removed[i]), low, high, dispatcher);
  }
  // Additions: room for all of them first, then each slot and the higher
  // proxy (read by the overlap filter) fetched ahead.
  reserve(keys_.size() + added.size());
  for (std::size_t i = 0; i < added.size(); ++i) {
    if (i + kAhead < added.size()) {
      prefetchSlot(keyOf(added[i + kAhead]));
      if (btBroadphaseProxy* next = proxies[added[i + kAhead].b]; next != nullptr) prefetch(next);
    }
    if (i + 4 * kAhead < added.size()) prefetch(&proxies[added[i + 4 * kAhead].b]);
    btBroadphaseProxy* low = proxies[added[i].a];
    btBroadphaseProxy* high = proxies[added[i].b];
    if (low != nullptr && high != nullptr && needsBroadphaseCollision(low, high)) {
      addOrdered(low, high);
    }
  }
}

btBroadphasePair* BulkPairCache::addOverlappingPair(btBroadphaseProxy* proxy0,
                                                    btBroadphaseProxy* proxy1) {
  if (refusal_ || !needsBroadphaseCollision(proxy0, proxy1)) return nullptr;
  if (proxy0->m_uniqueId > proxy1->m_uniqueId) std::swap(proxy0, proxy1);
  try {
    return addOrdered(proxy0, proxy1);
  } catch (const PairMemoryError& refused) {  // never through Bullet's frames
    // Bullet's broadphase hands its pairs over one by one: the frame has
    // more than those held, how many more it cannot say.
    refusal_ = PairMemoryError(refused.pairs - 1, refused.bytes, refused.limit, true);
    return nullptr;
  }
}

void* BulkPairCache::removeOverlappingPair(btBroadphaseProxy* proxy0, btBroadphaseProxy* proxy1,
                                           btDispatcher* dispatcher) {
  if (proxy0->m_uniqueId > proxy1->m_uniqueId) std::swap(proxy0, proxy1);
  return removeOrdered(proxy0, proxy1, dispatcher);
}

btBroadphasePair* BulkPairCache::findPair(btBroadphaseProxy* proxy0, btBroadphaseProxy* proxy1) {
  if (proxy0->m_uniqueId > proxy1->m_uniqueId) std::swap(proxy0, proxy1);
  const IndexSlot& slot = index_[slotOf(orderedKey(proxy0->m_uniqueId, proxy1->m_uniqueId))];
  return slot.key == kEmpty ? nullptr : &pairs_[static_cast<int>(slot.pair)];
}

bool BulkPairCache::needsBroadphaseCollision(btBroadphaseProxy* proxy0,
                                             btBroadphaseProxy* proxy1) const {
  if (filter_ != nullptr) return filter_->needBroadphaseCollision(proxy0, proxy1);
  return (proxy0->m_collisionFilterGroup & proxy1->m_collisionFilterMask) != 0 &&
         (proxy1->m_collisionFilterGroup & proxy0->m_collisionFilterMask) != 0;
}

void BulkPairCache::cleanOverlappingPair(btBroadphasePair& pair, btDispatcher* dispatcher) {
  if (pair.m_algorithm != nullptr && dispatcher != nullptr) {
    pair.m_algorithm->~btCollisionAlgorithm();
    dispatcher->freeCollisionAlgorithm(pair.m_algorithm);
    pair.m_algorithm = nullptr;
  }
}

void BulkPairCache::processAllOverlappingPairs(btOverlapCallback* callback,
                                               btDispatcher* dispatcher) {
  for (int i = 0; i < pairs_.size();) {
    btBroadphasePair* pair = &pairs_[i];
    if (callback->processOverlap(*pair)) {
      removeOverlappingPair(pair->m_pProxy0, pair->m_pProxy1, dispatcher);
    } else {
      ++i;
    }
  }
}

// Bullet's deterministic visit, step for step: by descending (id0, id1),
// and after a removal the same step again (now on whatever moved into the
// removed pair's place).
void BulkPairCache::processAllOverlappingPairs(btOverlapCallback* callback,
                                               btDispatcher* dispatcher,
                                               const btDispatcherInfo& dispatchInfo) {
  if (!dispatchInfo.m_deterministicOverlappingPairs) {
    processAllOverlappingPairs(callback, dispatcher);
    return;
  }
  std::vector<Visit> order(static_cast<std::size_t>(pairs_.size()));
  for (int i = 0; i < pairs_.size(); ++i) order[static_cast<std::size_t>(i)] = visitOf(i);
  sortForVisit(order);
  for (std::size_t i = 0; i < order.size();) {
    btBroadphasePair* pair = &pairs_[order[i].index];
    if (callback->processOverlap(*pair)) {
      removeOverlappingPair(pair->m_pProxy0, pair->m_pProxy1, dispatcher);
    } else {
      ++i;
    }
  }
}

void BulkPairCache::processPairsInVisitOrder(std::span<const int> indices,
                                             btOverlapCallback* callback,
                                             const btDispatcherInfo& dispatchInfo) {
  const auto visit = [&](int index) {
    if (callback->processOverlap(pairs_[index])) {
      throw std::logic_error("BulkPairCache::processPairsInVisitOrder: a pair asked for removal");
    }
  };
  if (!dispatchInfo.m_deterministicOverlappingPairs) {
    for (const int index : indices) visit(index);
    return;
  }
  visits_.clear();
  for (const int index : indices) visits_.push_back(visitOf(index));
  sortForVisit(visits_);
  for (const Visit& next : visits_) visit(next.index);
}

BulkPairCache::Visit BulkPairCache::visitOf(int index) const {
  const btBroadphasePair& pair = pairs_[index];
  const int id0 = pair.m_pProxy0 != nullptr ? pair.m_pProxy0->m_uniqueId : -1;
  const int id1 = pair.m_pProxy1 != nullptr ? pair.m_pProxy1->m_uniqueId : -1;
  // Flipping the sign bit orders signed ids as unsigned ones.
  return Visit{orderedKey(id0, id1) ^ 0x8000000080000000ULL, index};
}

void BulkPairCache::sortForVisit(std::vector<Visit>& visits) {
  std::sort(visits.begin(), visits.end(),
            [](const Visit& x, const Visit& y) { return x.key > y.key; });
}

void BulkPairCache::cleanProxyFromPairs(btBroadphaseProxy* proxy, btDispatcher* dispatcher) {
  struct Clean : btOverlapCallback {
    Clean(btBroadphaseProxy* clean_proxy, BulkPairCache* cache, btDispatcher* pair_dispatcher)
        : proxy(clean_proxy), owner(cache), dispatcher(pair_dispatcher) {}
    bool processOverlap(btBroadphasePair& pair) override {
      if (pair.m_pProxy0 == proxy || pair.m_pProxy1 == proxy) {
        owner->cleanOverlappingPair(pair, dispatcher);
      }
      return false;
    }
    btBroadphaseProxy* proxy;
    BulkPairCache* owner;
    btDispatcher* dispatcher;
  };
  Clean clean(proxy, this, dispatcher);
  processAllOverlappingPairs(&clean, dispatcher);
}

void BulkPairCache::removeOverlappingPairsContainingProxy(btBroadphaseProxy* proxy,
                                                          btDispatcher* dispatcher) {
  struct Remove : btOverlapCallback {
    explicit Remove(btBroadphaseProxy* obsolete) : proxy(obsolete) {}
    bool processOverlap(btBroadphasePair& pair) override {
      return pair.m_pProxy0 == proxy || pair.m_pProxy1 == proxy;
    }
    btBroadphaseProxy* proxy;
  };
  Remove remove(proxy);
  processAllOverlappingPairs(&remove, dispatcher);
}

// As Bullet: every pair removed (its algorithm freed), then added back in
// btBroadphasePairSortPredicate's order.
void BulkPairCache::sortOverlappingPairs(btDispatcher* dispatcher) {
  std::vector<btBroadphasePair> pairs(&pairs_[0], &pairs_[0] + pairs_.size());
  for (const btBroadphasePair& pair : pairs) {
    removeOverlappingPair(pair.m_pProxy0, pair.m_pProxy1, dispatcher);
  }
  // Pairs are unique, so any sort gives Bullet's quickSort order.
  std::sort(pairs.begin(), pairs.end(), btBroadphasePairSortPredicate());
  for (const btBroadphasePair& pair : pairs) addOverlappingPair(pair.m_pProxy0, pair.m_pProxy1);
}

}  // namespace overlap::physics
