#include "physics/broadphase/broadphase_factory.h"

#include <BulletCollision/BroadphaseCollision/btAxisSweep3.h>
#include <BulletCollision/BroadphaseCollision/btDbvtBroadphase.h>
#include <BulletCollision/BroadphaseCollision/btSimpleBroadphase.h>

#include <cstdlib>
#include <new>
#include <stdexcept>
#include <string>

#include "physics/broadphase/bulk_pair_cache.h"
#include "physics/broadphase/ccd_query_broadphase.h"
#include "physics/broadphase/growing_sweep_and_prune.h"
#include "physics/broadphase/pair_finder_broadphase.h"

namespace overlap::physics {
namespace {

// btAxisSweep3 stores handles in 16 bits and reserves a few for itself.
constexpr int kMaxSap16Objects = 32766;

// Bullet's own broadphases with our pair cache, which holds the same pairs in
// the same order as theirs (physics/broadphase/bulk_pair_cache.h) but checks its
// allocations and can be bounded.  The cache is the first base, so it is
// built before the broadphase that keeps a pointer to it and outlives it.
struct PairCacheOwner {
  BulkPairCache cache;
};

class BruteForceBroadphase final : private PairCacheOwner, public btSimpleBroadphase {
 public:
  explicit BruteForceBroadphase(int max_objects) : btSimpleBroadphase(max_objects, &cache) {}
};

template <class Sweep, class Handle>
class SweepBroadphase final : private PairCacheOwner, public Sweep {
 public:
  SweepBroadphase(const btVector3& world_min, const btVector3& world_max, Handle handles)
      // No ray-test tree of its own: makeWorldBroadphase() answers every
      // broadphase's ray and sweep queries through one shared tree.
      : Sweep(world_min, world_max, handles, &cache, true) {}
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

constexpr BulletRow kBulletRows[] = {
    {{"bf", true, false, "Bullet's btSimpleBroadphase: every pair tested (the paper's BF)"},
     [](const btVector3&, const btVector3&,
        int max_objects) -> std::unique_ptr<btBroadphaseInterface> {
       return std::make_unique<BruteForceBroadphase>(max_objects);
     }},
    {{"sap", false, false,
      "Bullet's btAxisSweep3: sweep and prune on 16-bit quantized bounds, under 32766 objects"},
     [](const btVector3& world_min, const btVector3& world_max,
        int max_objects) -> std::unique_ptr<btBroadphaseInterface> {
       if (const std::string problem = broadphaseCapacityProblem("sap", max_objects);
           !problem.empty()) {
         throw std::invalid_argument("algo sap: " + problem);
       }
       return std::make_unique<SweepBroadphase<GrowingAxisSweep16, unsigned short>>(
           world_min, world_max, static_cast<unsigned short>(max_objects + 1));
     }},
    {{"sap32", false, false,
      "Bullet's bt32BitAxisSweep3: sweep and prune on 32-bit quantized bounds"},
     [](const btVector3& world_min, const btVector3& world_max,
        int max_objects) -> std::unique_ptr<btBroadphaseInterface> {
       return std::make_unique<SweepBroadphase<GrowingAxisSweep32, unsigned int>>(
           world_min, world_max, static_cast<unsigned int>(max_objects + 1));
     }},
    {{"bvh", false, false, "Bullet's btDbvtBroadphase: trees of fattened boxes (the paper's BVH)"},
     [](const btVector3&, const btVector3&, int) -> std::unique_ptr<btBroadphaseInterface> {
       return std::make_unique<TreeBroadphase>();
     }},
};

// Bullet's allocations return null when memory runs out, and Bullet writes
// through it: a signal.  Through this allocator they throw std::bad_alloc.
void* checkedAllocation(std::size_t bytes) {
  void* memory = std::malloc(bytes);
  if (memory == nullptr) throw std::bad_alloc();
  return memory;
}

void checkBulletAllocations() {
  static const bool installed = [] {
    btAlignedAllocSetCustom(checkedAllocation, std::free);
    return true;
  }();
  (void)installed;
}

}  // namespace

BroadphaseCatalogue::BroadphaseCatalogue(std::span<const finders::PairFinderRow> finders)
    : finders_(finders.begin(), finders.end()) {
  for (const BulletRow& row : kBulletRows) entries_.push_back(row.info);
  // Every pair finder is exact (gpu/pair_finder.h).
  for (const finders::PairFinderRow& row : finders_) {
    entries_.push_back({row.name, true, row.needs_device, row.description});
  }
  for (const BroadphaseInfo& info : entries_) names_.push_back(info.name);
}

const BroadphaseInfo& BroadphaseCatalogue::info(std::string_view name) const {
  for (const BroadphaseInfo& info : entries_) {
    if (info.name == name) return info;
  }
  throw std::invalid_argument("algo: unknown broadphase '" + std::string(name) + "'");
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
  checkBulletAllocations();
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
