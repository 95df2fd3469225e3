#include "physics/broadphase_replay.h"

#include <btBulletCollisionCommon.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "gpu/base/interrupt.h"
#include "physics/broadphase/broadphase_factory.h"
#include "physics/broadphase/bulk_pair_cache.h"
#include "physics/broadphase/growing_sweep_and_prune.h"
#include "physics/broadphase/pair_finder_broadphase.h"

namespace overlap::physics {

struct BroadphaseReplay::Bullet {
  btDefaultCollisionConfiguration collision_config;
  btCollisionDispatcher dispatcher{&collision_config};
  std::unique_ptr<btBroadphaseInterface> broadphase;
  std::vector<btBroadphaseProxy*> proxies;
  std::vector<int> indices;  // proxies' user pointers point here
  // The cache under a memory limit (setPairMemoryLimit), else null: a pair
  // it refuses inside a Bullet call is thrown after that call returns.
  BulkPairCache* bounded = nullptr;
  void throwIfPairsRefused() const {
    if (bounded != nullptr) bounded->throwIfRefused();
  }
  std::vector<Aabb> written;  // each proxy's box as last written

  ~Bullet() {
    if (broadphase == nullptr) return;  // the factory refused the algorithm or the count
    // Every pair at once: destroyProxy() alone would walk the whole cache for
    // each proxy (Bullet's removeOverlappingPairsContainingProxy), n times.
    struct RemoveEvery final : btOverlapCallback {
      bool processOverlap(btBroadphasePair& /*pair*/) override { return true; }
    } remove_every;
    broadphase->getOverlappingPairCache()->processAllOverlappingPairs(&remove_every, &dispatcher);
    // A sweep and prune keeps its handles in one array, which its destructor
    // frees whole (makeBroadphase() gives it no ray-test tree of proxies of
    // its own); removing them one by one would sort each handle's edges to
    // the end of every axis, n^2 in all.
    if (isSweepAndPrune(*broadphase)) return;
    for (btBroadphaseProxy* proxy : proxies) {
      if (proxy != nullptr) broadphase->destroyProxy(proxy, &dispatcher);
    }
  }
};

namespace {

constexpr std::size_t kProxiesBetweenChecks = 256;
// The replay's own per box: its proxy's pointer, index and last written box.
constexpr std::uint32_t kBytesPerBox = sizeof(btBroadphaseProxy*) + sizeof(int) + sizeof(Aabb);

btVector3 corner(const float (&xyz)[3]) {
  return {xyz[0], xyz[1], xyz[2]};
}

}  // namespace

BroadphaseReplay::BroadphaseReplay(std::string_view algorithm, const Aabb& world, int objects,
                                   TaskSystem& tasks)
    : bullet_(std::make_unique<Bullet>()) {
  if (objects <= 0) throw std::invalid_argument("objects: must be positive");
  // A margin keeps boxes on the world's boundary off SAP's clamped edge.
  const btVector3 lo = corner(world.min), hi = corner(world.max);
  const btVector3 margin = (hi - lo) * 0.125f + btVector3(1, 1, 1);
  BroadphaseChoice choice = makeBroadphase(algorithm, lo - margin, hi + margin, objects, tasks);
  algorithm_ = choice.name;
  notice_ = choice.notice;
  Bullet& b = *bullet_;
  b.broadphase = std::move(choice.broadphase);
  b.indices.resize(static_cast<std::size_t>(objects));
  for (int i = 0; i < objects; ++i) b.indices[static_cast<std::size_t>(i)] = i;
}

BroadphaseReplay::~BroadphaseReplay() = default;

void BroadphaseReplay::update(std::span<const Aabb> boxes, std::span<const std::uint8_t> present) {
  Bullet& b = *bullet_;
  if (boxes.size() != b.indices.size() || (!present.empty() && present.size() != boxes.size())) {
    throw std::invalid_argument("replay: frame has " + std::to_string(boxes.size()) +
                                " boxes, expected " + std::to_string(b.indices.size()));
  }
  if (!present.empty()) {
    updatePresent(boxes, present);
    return;
  }
  // Proxies are created at the first frame's boxes: SAP and DBVT pair a new
  // proxy with everything it overlaps at once, so n proxies created at one
  // point would fill the pair cache with n^2/2 pairs, and Bullet's hashed
  // cache never shrinks its table back.
  if (b.proxies.empty()) {
    b.proxies.reserve(boxes.size());
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      // A sweep and prune inserts a proxy in time proportional to those it
      // holds: creating many is a long step, stopped by a signal within it.
      if (i % kProxiesBetweenChecks == 0 && pendingInterrupt() != 0) {
        stopIfInterrupted("the first frame, creating box " + std::to_string(i) + " of " +
                          std::to_string(boxes.size()) + " in the broadphase");
      }
      b.proxies.push_back(b.broadphase->createProxy(
          corner(boxes[i].min), corner(boxes[i].max), BOX_SHAPE_PROXYTYPE, &b.indices[i],
          btBroadphaseProxy::DefaultFilter, btBroadphaseProxy::AllFilter, &b.dispatcher));
      b.throwIfPairsRefused();
    }
    b.written.assign(boxes.begin(), boxes.end());
    return;
  }
  // Only the boxes that changed, as a world skips its sleeping bodies.
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    if (std::memcmp(&boxes[i], &b.written[i], sizeof(Aabb)) == 0) continue;
    b.written[i] = boxes[i];
    b.broadphase->setAabb(b.proxies[i], corner(boxes[i].min), corner(boxes[i].max), &b.dispatcher);
  }
  b.throwIfPairsRefused();
}

void BroadphaseReplay::updateChanged(std::span<const Aabb> boxes,
                                     std::span<const std::uint32_t> changed) {
  Bullet& b = *bullet_;
  if (boxes.size() != b.indices.size() || b.written.size() != boxes.size()) {
    throw std::invalid_argument(
        "replay: updateChanged needs a frame of " + std::to_string(b.indices.size()) +
        " boxes after the first update, got " + std::to_string(boxes.size()));
  }
  for (const std::uint32_t i : changed) {
    if (i >= boxes.size() || b.proxies[i] == nullptr) {
      throw std::invalid_argument("replay: changed object " + std::to_string(i) + " has no proxy");
    }
    b.written[i] = boxes[i];
    b.broadphase->setAabb(b.proxies[i], corner(boxes[i].min), corner(boxes[i].max), &b.dispatcher);
  }
  b.throwIfPairsRefused();
}

void BroadphaseReplay::updatePresent(std::span<const Aabb> boxes,
                                     std::span<const std::uint8_t> present) {
  Bullet& b = *bullet_;
  b.proxies.resize(boxes.size(), nullptr);
  b.written.assign(boxes.begin(), boxes.end());
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    if (present[i] == 0 && b.proxies[i] != nullptr) {
      b.broadphase->destroyProxy(b.proxies[i], &b.dispatcher);
      b.proxies[i] = nullptr;
    }
  }
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    if (present[i] == 0) continue;
    if (b.proxies[i] == nullptr) {
      b.proxies[i] = b.broadphase->createProxy(
          corner(boxes[i].min), corner(boxes[i].max), BOX_SHAPE_PROXYTYPE, &b.indices[i],
          btBroadphaseProxy::DefaultFilter, btBroadphaseProxy::AllFilter, &b.dispatcher);
    } else {
      b.broadphase->setAabb(b.proxies[i], corner(boxes[i].min), corner(boxes[i].max),
                            &b.dispatcher);
    }
  }
  b.throwIfPairsRefused();
}

std::optional<ReplayPhases> BroadphaseReplay::lastPhases() const {
  const auto* ours = dynamic_cast<const PairFinderBroadphase*>(bullet_->broadphase.get());
  if (ours == nullptr) return std::nullopt;
  return ReplayPhases{ours->lastSearchStats(), ours->lastCacheUpdateMs()};
}

finders::MemoryCost BroadphaseReplay::memoryCost(std::string_view algorithm) {
  const bool falls_back =
      broadphaseInfo(algorithm).needs_device && !finders::cudaDeviceAvailable(nullptr);
  finders::MemoryCost cost = broadphaseInfo(falls_back ? kDeviceFallback : algorithm).memory;
  cost.per_slot += kBytesPerBox;
  cost.per_pair += sizeof(PairList::value_type);
  return cost;
}

void BroadphaseReplay::setPairMemoryLimit(std::uint64_t bytes, std::uint64_t caller_per_pair) {
  auto* cache = dynamic_cast<BulkPairCache*>(bullet_->broadphase->getOverlappingPairCache());
  if (cache == nullptr) throw std::logic_error("replay: the broadphase has no bulk pair cache");
  cache->setMemoryLimit(bytes, memoryCost(algorithm_).per_pair + caller_per_pair);
  bullet_->bounded = bytes != 0 ? cache : nullptr;
}

void BroadphaseReplay::findPairs(const std::function<std::string()>& where) {
  bullet_->broadphase->calculateOverlappingPairs(&bullet_->dispatcher);
  // A search a signal cut short is never handed on as if whole.
  if (pendingInterrupt() != 0) stopIfInterrupted(where());
  bullet_->throwIfPairsRefused();
}

PairList BroadphaseReplay::pairs() const {
  const btBroadphasePairArray& array =
      bullet_->broadphase->getOverlappingPairCache()->getOverlappingPairArray();
  PairList result;
  result.reserve(static_cast<std::size_t>(array.size()));
  for (int i = 0; i < array.size(); ++i) {
    const int a = *static_cast<const int*>(array[i].m_pProxy0->m_clientObject);
    const int b = *static_cast<const int*>(array[i].m_pProxy1->m_clientObject);
    result.push_back(orderedPair(a, b));
  }
  std::sort(result.begin(), result.end());
  return result;
}

}  // namespace overlap::physics
