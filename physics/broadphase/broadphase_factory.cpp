#include "physics/broadphase/broadphase_factory.h"

#include <BulletCollision/BroadphaseCollision/btAxisSweep3.h>
#include <BulletCollision/BroadphaseCollision/btDbvtBroadphase.h>
#include <BulletCollision/BroadphaseCollision/btSimpleBroadphase.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <new>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>

#include "gpu/base/interrupt.h"
#include "gpu/base/shown_value.h"
#include "physics/broadphase/bulk_pair_cache.h"
#include "physics/broadphase/ccd_query_broadphase.h"
#include "physics/broadphase/growing_sweep_and_prune.h"
#include "physics/broadphase/pair_finder_broadphase.h"

namespace overlap::physics {
namespace {

// btAxisSweep3 stores handles in 16 bits and reserves a few for itself.
constexpr int kMaxSap16Objects = 32766;

// What Bullet's bf, sap and sap32 throw when a proxy past the max_objects
// they were made for is added: Bullet's own would hand out a broken one.
[[noreturn]] void throwMaxObjectsExceeded(std::string_view name, int max_objects) {
  throw std::invalid_argument("algo " + std::string(name) + ": made with max_objects " +
                              std::to_string(max_objects) +
                              ", and one more proxy was added; make it with a larger max_objects");
}

// Bullet's own broadphases with our pair cache, which holds the same pairs in
// the same order as theirs (physics/broadphase/bulk_pair_cache.h) but checks its
// allocations and can be bounded.  The cache is the first base, so it is
// built before the broadphase that keeps a pointer to it and outlives it.
struct PairCacheOwner {
  BulkPairCache cache;
};

class BruteForceBroadphase final : private PairCacheOwner, public btSimpleBroadphase {
 public:
  // Bullet's writes before its handles when made for none: it gets one.
  explicit BruteForceBroadphase(int max_objects)
      : btSimpleBroadphase(std::max(max_objects, 1), &cache), max_objects_(max_objects) {}

  // Bullet's returns null past max_objects, and its world writes through it.
  btBroadphaseProxy* createProxy(const btVector3& aabbMin, const btVector3& aabbMax, int shapeType,
                                 void* userPtr, int collisionFilterGroup, int collisionFilterMask,
                                 btDispatcher* dispatcher) override {
    if (m_numHandles >= max_objects_) throwMaxObjectsExceeded("bf", max_objects_);
    return btSimpleBroadphase::createProxy(aabbMin, aabbMax, shapeType, userPtr,
                                           collisionFilterGroup, collisionFilterMask, dispatcher);
  }

  // Bullet's pass, pair for pair and in its order (the same pairs, the same
  // cache), with a look at the signal flag every kRowsPerLook rows: a frame
  // of 150k boxes is minutes, and a signal cuts it short (the world then
  // stops, gpu/base/interrupt.h).  Bullet's deferred-removal branch is only
  // for a cache the broadphase owns, which this one never does.
  void calculateOverlappingPairs(btDispatcher* dispatcher) override {
    constexpr int kRowsPerLook = 64;
    int last_used = -1;
    for (int i = 0; i <= m_LastHandleIndex; ++i) {
      if (i % kRowsPerLook == 0 && pendingInterrupt() != 0) return;
      btSimpleBroadphaseProxy* proxy0 = &m_pHandles[i];
      if (proxy0->m_clientObject == nullptr) continue;
      last_used = i;
      for (int j = i + 1; j <= m_LastHandleIndex; ++j) {
        btSimpleBroadphaseProxy* proxy1 = &m_pHandles[j];
        if (proxy1->m_clientObject == nullptr) continue;
        if (aabbOverlap(proxy0, proxy1)) {
          if (m_pairCache->findPair(proxy0, proxy1) == nullptr) {
            m_pairCache->addOverlappingPair(proxy0, proxy1);
          }
        } else if (!m_pairCache->hasDeferredRemoval() &&
                   m_pairCache->findPair(proxy0, proxy1) != nullptr) {
          m_pairCache->removeOverlappingPair(proxy0, proxy1, dispatcher);
        }
      }
    }
    m_LastHandleIndex = last_used;
  }

 private:
  int max_objects_;
};

template <class Sweep, class Handle>
class SweepBroadphase final : private PairCacheOwner, public Sweep {
 public:
  SweepBroadphase(const btVector3& world_min, const btVector3& world_max, int max_objects)
      // No ray-test tree of its own: makeWorldBroadphase() answers every
      // broadphase's ray and sweep queries through one shared tree.  Bullet
      // adds its sentinel handle to these, and takes it for a proxy when
      // made for none.
      : Sweep(world_min, world_max, static_cast<Handle>(std::max(max_objects, 1)), &cache, true),
        max_objects_(max_objects) {}

  btBroadphaseProxy* createProxy(const btVector3& aabbMin, const btVector3& aabbMax, int shapeType,
                                 void* userPtr, int collisionFilterGroup, int collisionFilterMask,
                                 btDispatcher* dispatcher) override {
    if (static_cast<int>(this->m_numHandles) >= max_objects_) {
      throwMaxObjectsExceeded(name(), max_objects_);
    }
    return Sweep::createProxy(aabbMin, aabbMax, shapeType, userPtr, collisionFilterGroup,
                              collisionFilterMask, dispatcher);
  }

 private:
  static constexpr std::string_view name() {
    return std::is_same_v<Handle, unsigned short> ? "sap" : "sap32";
  }
  int max_objects_;
};

class TreeBroadphase final : private PairCacheOwner, public btDbvtBroadphase {
 public:
  TreeBroadphase() : btDbvtBroadphase(&cache) {}
};

// Bullet's broadphases: the catalogue's first entries, each with what makes it.
struct BulletRow {
  BroadphaseInfo info;
  std::unique_ptr<btBroadphaseInterface> (*make)(const btVector3& world_min,
                                                 const btVector3& world_max, int max_objects);
};

// Each row's memory: what it holds per proxy, growth room included, about
// 1.5x what tests/physics/broadphase_memory_test.cpp measured (bf 57 bytes,
// sap 97, sap32 137, bvh 304 at 10000 boxes; bvh's tree walks keep a stack
// of node pairs besides, up to 300 bytes a box where every box overlaps).
constexpr BulletRow kBulletRows[] = {
    {{"bf",
      true,
      false,
      "Bullet's btSimpleBroadphase: every pair tested (the paper's BF)",
      {.per_slot = 96}},
     [](const btVector3&, const btVector3&,
        int max_objects) -> std::unique_ptr<btBroadphaseInterface> {
       return std::make_unique<BruteForceBroadphase>(max_objects);
     }},
    {{"sap",
      false,
      false,
      "Bullet's btAxisSweep3: sweep and prune on 16-bit quantized bounds, under 32766 objects",
      {.per_slot = 160}},
     [](const btVector3& world_min, const btVector3& world_max,
        int max_objects) -> std::unique_ptr<btBroadphaseInterface> {
       if (const std::string problem = broadphaseCapacityProblem("sap", max_objects);
           !problem.empty()) {
         throw std::invalid_argument("algo sap: " + problem);
       }
       return std::make_unique<SweepBroadphase<GrowingAxisSweep16, unsigned short>>(
           world_min, world_max, max_objects);
     }},
    {{"sap32",
      false,
      false,
      "Bullet's bt32BitAxisSweep3: sweep and prune on 32-bit quantized bounds",
      {.per_slot = 224}},
     [](const btVector3& world_min, const btVector3& world_max,
        int max_objects) -> std::unique_ptr<btBroadphaseInterface> {
       return std::make_unique<SweepBroadphase<GrowingAxisSweep32, unsigned int>>(
           world_min, world_max, max_objects);
     }},
    {{"bvh",
      false,
      false,
      "Bullet's btDbvtBroadphase: trees of fattened boxes (the paper's BVH)",
      {.per_slot = 768}},
     [](const btVector3&, const btVector3&, int) -> std::unique_ptr<btBroadphaseInterface> {
       return std::make_unique<TreeBroadphase>();
     }},
};

// Bullet's allocations return null when memory runs out, and Bullet writes
// through it: a signal.  Through this allocator they throw std::bad_alloc.
// It is installed as the program starts, before any Bullet object (a
// btDefaultCollisionConfiguration's pools are allocated before any
// broadphase): every program that links this library gets it.
void* checkedAllocation(std::size_t bytes) {
  void* memory = std::malloc(bytes);
  if (memory == nullptr) throw std::bad_alloc();
  return memory;
}

[[maybe_unused]] const bool kBulletAllocationsChecked = [] {
  btAlignedAllocSetCustom(checkedAllocation, std::free);
  return true;
}();

}  // namespace

BroadphaseCatalogue::BroadphaseCatalogue(std::span<const finders::PairFinderRow> finders)
    : finders_(finders.begin(), finders.end()) {
  for (const BulletRow& row : kBulletRows) entries_.push_back(row.info);
  // Every pair finder is exact (gpu/pair_finder.h).
  for (const finders::PairFinderRow& row : finders_) {
    finders::MemoryCost memory = row.memory;
    memory.per_slot += PairFinderBroadphase::kBytesPerSlot;
    entries_.push_back({row.name, true, row.needs_device, row.description, memory});
  }
  for (const BroadphaseInfo& info : entries_) names_.push_back(info.name);
}

const BroadphaseInfo& BroadphaseCatalogue::info(std::string_view name) const {
  for (const BroadphaseInfo& info : entries_) {
    if (info.name == name) return info;
  }
  throw std::invalid_argument("algo: unknown broadphase '" + shownValue(name) + "'");
}

std::string broadphaseCapacityProblem(std::string_view name, int objects, int reserved) {
  if (name != "sap" || objects + reserved < kMaxSap16Objects) return {};
  const std::string most = std::to_string(kMaxSap16Objects - 1 - reserved);
  return "holds at most " +
         (reserved == 0 ? most + " objects"
                        : most + " boxes beside the scene's " + std::to_string(reserved) +
                              " other proxies (its walls, room for added objects)") +
         ", asked for " + std::to_string(objects) + "; use sap32";
}

BroadphaseChoice BroadphaseCatalogue::make(std::string_view name, const btVector3& world_min,
                                           const btVector3& world_max, int max_objects,
                                           TaskSystem& tasks) const {
  const BroadphaseInfo& info = this->info(name);
  if (max_objects < 0) {
    throw std::invalid_argument("algo " + std::string(name) + ": max_objects " +
                                std::to_string(max_objects) + " is negative");
  }
  // SAP quantizes inside the bounds: a NaN or infinite one pairs everything.
  for (int axis = 0; axis < 3; ++axis) {
    if (!std::isfinite(world_min[axis]) || !std::isfinite(world_max[axis]) ||
        !(world_min[axis] <= world_max[axis])) {
      throw std::invalid_argument("algo " + std::string(name) + ": the world bounds' axis " +
                                  std::to_string(axis) + " is not a finite min <= max");
    }
  }
  BroadphaseChoice choice;
  choice.name = std::string(name);
  for (const BulletRow& row : kBulletRows) {
    if (row.info.name == name) {
      choice.broadphase = row.make(world_min, world_max, max_objects);
      return choice;
    }
  }
  std::string why;
  if (info.needs_device && !finders::cudaDeviceAvailable(&why)) {
    choice = make(kDeviceFallback, world_min, world_max, max_objects, tasks);
    choice.notice =
        "algo " + std::string(name) + ": " + why + "; running " + choice.name + " instead";
    return choice;
  }
  choice.broadphase = std::make_unique<PairFinderBroadphase>(
      finders::makePairFinder(name, tasks, finders_), info.needs_device);
  return choice;
}

WorldBroadphaseChoice BroadphaseCatalogue::makeWorld(std::string_view name,
                                                     const btVector3& world_min,
                                                     const btVector3& world_max, int max_objects,
                                                     TaskSystem& tasks) const {
  BroadphaseChoice choice = make(name, world_min, world_max, max_objects, tasks);
  return {std::make_unique<CcdQueryBroadphase>(std::move(choice.broadphase)),
          std::move(choice.name), std::move(choice.notice)};
}

const BroadphaseCatalogue& productCatalogue() {
  static const BroadphaseCatalogue catalogue;
  return catalogue;
}

std::span<const BroadphaseInfo> broadphaseCatalogue() {
  return productCatalogue().entries();
}

std::span<const std::string_view> broadphaseNames() {
  return productCatalogue().names();
}

const BroadphaseInfo& broadphaseInfo(std::string_view name) {
  return productCatalogue().info(name);
}

BroadphaseChoice makeBroadphase(std::string_view name, const btVector3& world_min,
                                const btVector3& world_max, int max_objects, TaskSystem& tasks) {
  return productCatalogue().make(name, world_min, world_max, max_objects, tasks);
}

WorldBroadphaseChoice makeWorldBroadphase(std::string_view name, const btVector3& world_min,
                                          const btVector3& world_max, int max_objects,
                                          TaskSystem& tasks) {
  return productCatalogue().makeWorld(name, world_min, world_max, max_objects, tasks);
}

}  // namespace overlap::physics
