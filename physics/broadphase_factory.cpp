#include "physics/broadphase_factory.h"

#include <BulletCollision/BroadphaseCollision/btAxisSweep3.h>
#include <BulletCollision/BroadphaseCollision/btDbvtBroadphase.h>
#include <BulletCollision/BroadphaseCollision/btSimpleBroadphase.h>

#include <array>
#include <cstdlib>
#include <new>
#include <stdexcept>
#include <string>

#include "physics/bulk_pair_cache.h"
#include "physics/ccd_query_broadphase.h"
#include "physics/growing_sweep_and_prune.h"
#include "physics/pair_finder_broadphase.h"

namespace overlap::physics {
namespace {

constexpr std::array<BroadphaseInfo, 9> kCatalogue = {{
    {"bf", true, false, "Bullet's btSimpleBroadphase: every pair tested (the paper's BF)"},
    {"sap", false, false,
     "Bullet's btAxisSweep3: sweep and prune on 16-bit quantized bounds, under 32766 objects"},
    {"sap32", false, false,
     "Bullet's bt32BitAxisSweep3: sweep and prune on 32-bit quantized bounds"},
    {"bvh", false, false, "Bullet's btDbvtBroadphase: trees of fattened boxes (the paper's BVH)"},
    {"cpubf", true, false, "ours: brute force on CPU threads, gpubf's twin and the reference"},
    {"cpusap", true, false,
     "ours: sort and sweep on CPU threads (AVX2), the fastest exact CPU finder"},
    {"gpubf", true, true, "ours: CUDA brute force, pairs as bits, only the changes copied back"},
    {"gpubf-paper", true, true,
     "the paper's CUDA brute force as published: a byte per pair, all copied back"},
    {"gpusap", true, true,
     "ours: CUDA sort and sweep (CUB), pairs kept on the device, only the changes copied back"},
}};

constexpr std::array<std::string_view, kCatalogue.size()> kNames = [] {
  std::array<std::string_view, kCatalogue.size()> names{};
  for (std::size_t i = 0; i < names.size(); ++i) names[i] = kCatalogue[i].name;
  return names;
}();

// btAxisSweep3 stores handles in 16 bits and reserves a few for itself.
constexpr int kMaxSap16Objects = 32766;

// Bullet's own broadphases with our pair cache, which holds the same pairs in
// the same order as theirs (physics/bulk_pair_cache.h) but checks its
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

std::span<const BroadphaseInfo> broadphaseCatalogue() {
  return kCatalogue;
}

std::span<const std::string_view> broadphaseNames() {
  return kNames;
}

const BroadphaseInfo& broadphaseInfo(std::string_view name) {
  for (const BroadphaseInfo& info : kCatalogue) {
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

BroadphaseChoice makeBroadphase(std::string_view name, const btVector3& world_min,
                                const btVector3& world_max, int max_objects) {
  const BroadphaseInfo& info = broadphaseInfo(name);
  checkBulletAllocations();
  BroadphaseChoice choice;
  choice.name = std::string(name);
  if (name == "bf") {
    choice.broadphase = std::make_unique<BruteForceBroadphase>(max_objects);
  } else if (name == "sap") {
    if (const std::string problem = broadphaseCapacityProblem(name, max_objects);
        !problem.empty()) {
      throw std::invalid_argument("algo sap: " + problem);
    }
    choice.broadphase = std::make_unique<SweepBroadphase<GrowingAxisSweep16, unsigned short>>(
        world_min, world_max, static_cast<unsigned short>(max_objects + 1));
  } else if (name == "sap32") {
    choice.broadphase = std::make_unique<SweepBroadphase<GrowingAxisSweep32, unsigned int>>(
        world_min, world_max, static_cast<unsigned int>(max_objects + 1));
  } else if (name == "bvh") {
    choice.broadphase = std::make_unique<TreeBroadphase>();
  } else if (name == "cpubf") {
    choice.broadphase = std::make_unique<PairFinderBroadphase>(
        finders::makePairFinder(finders::PairFinderKind::kCpuBruteForce));
  } else if (name == "cpusap") {
    choice.broadphase = std::make_unique<PairFinderBroadphase>(
        finders::makePairFinder(finders::PairFinderKind::kCpuSweepAndPrune));
  } else if (info.needs_device) {
    std::string why;
    if (finders::cudaDeviceAvailable(&why)) {
      choice.broadphase = std::make_unique<PairFinderBroadphase>(finders::makePairFinder(
          name == "gpubf"    ? finders::PairFinderKind::kGpuBruteForce
          : name == "gpusap" ? finders::PairFinderKind::kGpuSweepAndPrune
                             : finders::PairFinderKind::kGpuBruteForcePaper));
    } else {
      choice = makeBroadphase(kDeviceFallback, world_min, world_max, max_objects);
      choice.notice =
          "algo " + std::string(name) + ": " + why + "; running " + choice.name + " instead";
    }
  }
  return choice;
}

BroadphaseChoice makeWorldBroadphase(std::string_view name, const btVector3& world_min,
                                     const btVector3& world_max, int max_objects) {
  BroadphaseChoice choice = makeBroadphase(name, world_min, world_max, max_objects);
  choice.broadphase = std::make_unique<CcdQueryBroadphase>(std::move(choice.broadphase));
  return choice;
}

}  // namespace overlap::physics
