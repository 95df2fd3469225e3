#include "physics/broadphase/pair_finder_broadphase.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "gpu/base/stopwatch.h"
#include "gpu/pairs/pair_logic.h"

namespace overlap::physics {
PairFinderBroadphase::PairFinderBroadphase(std::unique_ptr<finders::PairFinder> finder,
                                           bool on_device)
    : finder_(std::move(finder)),
      on_device_(on_device),
      pair_cache_(std::make_unique<BulkPairCache>()) {
  if (finder_ == nullptr) throw std::runtime_error("PairFinderBroadphase: no pair finder given");
}

PairFinderBroadphase::~PairFinderBroadphase() = default;

btBroadphaseProxy* PairFinderBroadphase::createProxy(const btVector3& aabbMin,
                                                     const btVector3& aabbMax, int /*shapeType*/,
                                                     void* userPtr, int collisionFilterGroup,
                                                     int collisionFilterMask,
                                                     btDispatcher* /*dispatcher*/) {
  std::uint32_t slot = 0;
  if (!free_slots_.empty()) {
    slot = free_slots_.back();
    free_slots_.pop_back();
  } else {
    if (proxies_.size() >= static_cast<std::size_t>(std::numeric_limits<int>::max())) {
      throw std::runtime_error("PairFinderBroadphase: more proxies than m_uniqueId can number");
    }
    slot = static_cast<std::uint32_t>(proxies_.size());
    proxies_.emplace_back();
    states_.push_back(SlotState::kFree);
    live_proxies_.push_back(nullptr);
    aabb_valid_.push_back(true);
    search_entries_.emplace_back();
    changed_flags_.push_back(0);
  }
  // A free slot's old proxy has no pairs and no pending results: drop it.
  proxies_[slot] = std::make_unique<btBroadphaseProxy>(aabbMin, aabbMax, userPtr,
                                                       collisionFilterGroup, collisionFilterMask);
  proxies_[slot]->m_uniqueId = static_cast<int>(slot);
  states_[slot] = SlotState::kLive;
  live_proxies_[slot] = proxies_[slot].get();
  aabb_valid_[slot] = true;
  ++live_count_;
  updateSearchEntry(slot);
  return proxies_[slot].get();
}

std::uint32_t PairFinderBroadphase::liveSlotOf(const btBroadphaseProxy* proxy,
                                               const char* caller) const {
  const auto slot = static_cast<std::uint32_t>(proxy == nullptr ? -1 : proxy->m_uniqueId);
  if (proxy == nullptr || slot >= proxies_.size() || proxies_[slot].get() != proxy ||
      states_[slot] != SlotState::kLive) {
    throw std::runtime_error(std::string("PairFinderBroadphase::") + caller +
                             ": the proxy is not a live proxy of this broadphase");
  }
  return slot;
}

void PairFinderBroadphase::destroyProxy(btBroadphaseProxy* proxy, btDispatcher* dispatcher) {
  const std::uint32_t slot = liveSlotOf(proxy, "destroyProxy");
  pair_cache_->removeOverlappingPairsContainingProxy(proxy, dispatcher);
  states_[slot] = SlotState::kDestroyed;
  live_proxies_[slot] = nullptr;
  setSearchEntry(slot, finders::ObjectBounds{});
  destroyed_.push_back(slot);
  --live_count_;
}

void PairFinderBroadphase::setAabb(btBroadphaseProxy* proxy, const btVector3& aabbMin,
                                   const btVector3& aabbMax, btDispatcher* /*dispatcher*/) {
  const std::uint32_t slot = liveSlotOf(proxy, "setAabb");
  proxy->m_aabbMin = aabbMin;
  proxy->m_aabbMax = aabbMax;
  updateSearchEntry(slot);
}

void PairFinderBroadphase::getAabb(btBroadphaseProxy* proxy, btVector3& aabbMin,
                                   btVector3& aabbMax) const {
  aabbMin = proxy->m_aabbMin;
  aabbMax = proxy->m_aabbMax;
}

void PairFinderBroadphase::updateSearchEntry(std::uint32_t slot) {
  const btBroadphaseProxy& proxy = *proxies_[slot];
  finders::ObjectBounds entry;
  for (int axis = 0; axis < 3; ++axis) {
    entry.min[axis] = static_cast<float>(proxy.m_aabbMin[axis]);
    entry.max[axis] = static_cast<float>(proxy.m_aabbMax[axis]);
  }
  entry.group = proxy.m_collisionFilterGroup;
  entry.mask = proxy.m_collisionFilterMask;
  if (!finders::pair_logic::boundsOrdered(entry)) {
    if (aabb_valid_[slot]) {
      const btVector3& lo = proxy.m_aabbMin;
      const btVector3& hi = proxy.m_aabbMax;
      std::fprintf(stderr,
                   "PairFinderBroadphase: object %d (client object %p) has a NaN or "
                   "inverted AABB min (%g, %g, %g) max (%g, %g, %g); it is left out of pair "
                   "finding until it gets a valid AABB\n",
                   proxy.m_uniqueId, proxy.m_clientObject, double{lo.x()}, double{lo.y()},
                   double{lo.z()}, double{hi.x()}, double{hi.y()}, double{hi.z()});
    }
    aabb_valid_[slot] = false;
    setSearchEntry(slot, finders::ObjectBounds{});  // group = mask = 0: the search drops its pairs
    return;
  }
  aabb_valid_[slot] = true;
  setSearchEntry(slot, entry);
}

void PairFinderBroadphase::setSearchEntry(std::uint32_t slot, const finders::ObjectBounds& entry) {
  finders::ObjectBounds& held = search_entries_[slot];
  if (std::memcmp(&held, &entry, sizeof entry) == 0) return;
  held = entry;
  // Between searches the staging is ours to write (PairFinder::stagingFor).
  if (slot < staging_.size()) staging_[slot] = entry;
  if (changed_flags_[slot] == 0) {
    changed_flags_[slot] = 1;
    changed_slots_.push_back(slot);
  }
}

void PairFinderBroadphase::forEachSearchableProxy(
    const std::function<void(btBroadphaseProxy&)>& visit) {
  // By index: a callback may create proxies and so grow the vectors.
  for (std::size_t slot = 0; slot < proxies_.size(); ++slot) {
    if (states_[slot] == SlotState::kLive && aabb_valid_[slot]) visit(*proxies_[slot]);
  }
}

void PairFinderBroadphase::rayTest(const btVector3& rayFrom, const btVector3& /*rayTo*/,
                                   btBroadphaseRayCallback& rayCallback, const btVector3& aabbMin,
                                   const btVector3& aabbMax) {
  // As btDbvtBroadphase: each box is grown by the cast shape's AABB and slab
  // tested; m_lambda_max is read for every box, as a callback may shorten it.
  forEachSearchableProxy([&](btBroadphaseProxy& proxy) {
    const btVector3 bounds[2] = {proxy.m_aabbMin - aabbMax, proxy.m_aabbMax - aabbMin};
    btScalar entry_lambda = 0;
    if (btRayAabb2(rayFrom, rayCallback.m_rayDirectionInverse, rayCallback.m_signs, bounds,
                   entry_lambda, btScalar(0), rayCallback.m_lambda_max)) {
      rayCallback.process(&proxy);
    }
  });
}

void PairFinderBroadphase::aabbTest(const btVector3& aabbMin, const btVector3& aabbMax,
                                    btBroadphaseAabbCallback& callback) {
  forEachSearchableProxy([&](btBroadphaseProxy& proxy) {
    if (TestAabbAgainstAabb2(aabbMin, aabbMax, proxy.m_aabbMin, proxy.m_aabbMax)) {
      callback.process(&proxy);
    }
  });
}

void PairFinderBroadphase::calculateOverlappingPairs(btDispatcher* dispatcher) {
  launchFromStaging();
  last_search_wait_ms_ = 0;
  applySearch(dispatcher);
}

void PairFinderBroadphase::beginSearch(TaskGroup& beside) {
  if (searching_ != nullptr) throw std::logic_error("PairFinderBroadphase: search already begun");
  if (on_device_) {
    launchFromStaging();
  } else {
    beside.run([this] { launchFromStaging(); });
  }
  searching_ = &beside;
}

void PairFinderBroadphase::endSearch(btDispatcher* dispatcher) {
  if (searching_ == nullptr) throw std::logic_error("PairFinderBroadphase: no search begun");
  const HostStopwatch wait_watch;
  TaskGroup& group = *std::exchange(searching_, nullptr);
  group.wait();
  last_search_wait_ms_ = wait_watch.ms();
  applySearch(dispatcher);
}

void PairFinderBroadphase::applySearch(btDispatcher* dispatcher) {
  for (const std::uint32_t slot : changed_slots_) changed_flags_[slot] = 0;
  changed_slots_.clear();
  const HostStopwatch finish_watch;
  finders::PairDelta delta;
  try {
    delta = finder_->finish();
  } catch (const finders::PairLimitError& refusal) {
    pair_cache_->refuseMoreThan(refusal.most_pairs);
  }
  last_search_wait_ms_ += finish_watch.ms();
  const HostStopwatch cache_watch;
  // A pair with a destroyed proxy already left the cache with it: only pairs
  // of two live proxies apply.
  pair_cache_->applyChanges(delta.removed, delta.added, live_proxies_, dispatcher);
  // The search saw the destroyed slots unused, so the finder holds no pair of
  // theirs any more: they may take new proxies.
  for (const std::uint32_t slot : destroyed_) {
    states_[slot] = SlotState::kFree;
    free_slots_.push_back(slot);
  }
  destroyed_.clear();
  last_cache_update_ms_ = cache_watch.ms();
}

// Hands the boxes to the finder through its staging where it has one: only
// the slots added since the last search are copied there, the rest were
// written as they changed.
void PairFinderBroadphase::launchFromStaging() {
  finder_->setPairLimit(pair_cache_->mostPairs());
  const std::span<finders::ObjectBounds> staging = finder_->stagingFor(search_entries_.size());
  if (staging.empty()) {
    staging_ = {};
    finder_->launchWithChanges(search_entries_, changed_slots_);
    return;
  }
  // Same or fewer slots: the same memory, holding what was written to it.
  const std::size_t current = staging.size() <= staging_.size() ? staging.size() : 0;
  std::copy(search_entries_.begin() + static_cast<std::ptrdiff_t>(current), search_entries_.end(),
            staging.begin() + static_cast<std::ptrdiff_t>(current));
  staging_ = staging;
  finder_->launchWithChanges(staging_, changed_slots_);
}

void PairFinderBroadphase::getBroadphaseAabb(btVector3& aabbMin, btVector3& aabbMax) const {
  bool any = false;
  for (std::size_t slot = 0; slot < proxies_.size(); ++slot) {
    if (states_[slot] != SlotState::kLive || !aabb_valid_[slot]) continue;
    const btBroadphaseProxy& proxy = *proxies_[slot];
    if (any) {
      aabbMin.setMin(proxy.m_aabbMin);
      aabbMax.setMax(proxy.m_aabbMax);
    } else {
      aabbMin = proxy.m_aabbMin;
      aabbMax = proxy.m_aabbMax;
      any = true;
    }
  }
  if (!any) {
    aabbMin.setZero();
    aabbMax.setZero();
  }
}

void PairFinderBroadphase::resetPool(btDispatcher* /*dispatcher*/) {
  if (live_count_ != 0 || !destroyed_.empty()) return;
  std::sort(free_slots_.begin(), free_slots_.end(), std::greater<>());
}

void PairFinderBroadphase::printStats() {
  std::printf("PairFinderBroadphase (%.*s): %zu live proxies in %zu slots, %d cached pairs\n",
              static_cast<int>(finder_->name().size()), finder_->name().data(), live_count_,
              proxies_.size(), pair_cache_->getNumOverlappingPairs());
}

}  // namespace overlap::physics
