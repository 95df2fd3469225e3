// Broadphases by the names the paper and the CLI use, and their catalogue:
// every name, whether it is exact, whether it needs a CUDA device, and what
// it is.  Bullet's four are listed here; ours are the rows of the table of
// pair finders (gpu/pair_finder.h, finders::pairFinderTable()), each exact.  The
// CLI's --algo check and help, `overlap --list-algos`, the benchmark and the
// tests read the catalogue; README's table is checked against it
// (tests/physics/broadphase_catalogue_test.cpp).  The catalogue is a value:
// the free functions below use the product's, and a test may build one from
// a copy of the finder table with rows of its own.
//
// This is the package's public header (docs/PACKAGE.md): any Bullet program
// gets a btBroadphaseInterface by name from makeWorldBroadphase().
//
// Exact: the pair cache holds exactly the pairs whose AABBs overlap (touching
// counts).  Not exact: it holds all of them and may hold more.
// Every broadphase keeps its pairs in a BulkPairCache (physics/broadphase/bulk_pair_cache.h:
// the same pairs in the same order as Bullet's own cache), which checks its
// allocations and can be bounded; and from the program's start (before any
// Bullet object: linking this library installs it), Bullet's allocations
// throw std::bad_alloc when memory runs out instead of returning null.
// A device name without a CUDA device runs kDeviceFallback, the fastest exact
// CPU finder; the returned notice says so in one line, and `name` is what
// actually runs.
#pragma once

#include <btBulletCollisionCommon.h>

#include <concepts>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "gpu/pair_finder.h"
#include "physics/broadphase/ccd_query_broadphase.h"

namespace overlap::physics {

struct BroadphaseInfo {
  std::string_view name;
  bool exact;
  bool needs_device;             // runs on a CUDA device
  std::string_view description;  // one line
  // What it holds besides its pair cache, at most: Bullet's proxies and
  // trees, or our adapter's proxies plus the finder's own (gpu/pair_finder.h)
  // (tests/physics/broadphase_memory_test.cpp).
  finders::MemoryCost memory;
};

// Empty when broadphase `name` can hold `objects` proxies and `reserved`
// more (a world's walls), else why not, counting in `objects` as the user
// gave them (sap's 16-bit handles), so a command can refuse a count before
// any work.
std::string broadphaseCapacityProblem(std::string_view name, int objects, int reserved = 0);

// What a device name runs where there is no CUDA device.
inline constexpr std::string_view kDeviceFallback = "cpusap";

// A broadphase by name, and what runs.  make() gives the pair search alone
// (BroadphaseChoice); makeWorld() that search inside the shared query tree
// (WorldBroadphaseChoice), whose query time its owner may read apart; it
// converts to a BroadphaseChoice.
template <typename Broadphase>
struct BasicBroadphaseChoice {
  std::unique_ptr<Broadphase> broadphase;
  std::string name;    // the algorithm that runs
  std::string notice;  // empty, or why it is not the one asked for

  template <typename Base>
  requires(std::derived_from<Broadphase, Base> && !std::same_as<Broadphase, Base>)
  operator BasicBroadphaseChoice<Base>() && {
    return {std::move(broadphase), std::move(name), std::move(notice)};
  }
};
using BroadphaseChoice = BasicBroadphaseChoice<btBroadphaseInterface>;
using WorldBroadphaseChoice = BasicBroadphaseChoice<CcdQueryBroadphase>;

// Every broadphase, Bullet's first, then one per pair finder of a table.
class BroadphaseCatalogue {
 public:
  explicit BroadphaseCatalogue(
      std::span<const finders::PairFinderRow> finders = finders::pairFinderTable());

  // Every entry; the first exact one (bf) is the reference the others are
  // checked against.
  std::span<const BroadphaseInfo> entries() const { return entries_; }
  // The entries' names, in their order.
  std::span<const std::string_view> names() const { return names_; }
  // The entry named `name`; throws std::invalid_argument for an unknown name.
  const BroadphaseInfo& info(std::string_view name) const;

  // The pair search alone (what the benchmark times).  `world_min`/`world_max`
  // are where objects are expected (SAP quantizes inside them first and grows
  // them around any box outside: physics/broadphase/growing_sweep_and_prune.h);
  // `max_objects` is the most proxies the run will create.  Throws
  // std::invalid_argument for an unknown name, a negative max_objects or
  // one the algorithm can't hold, or world bounds that are not finite with
  // min <= max on each axis.  Bullet's bf, sap and sap32 hold
  // max_objects proxies at most: one more throws std::invalid_argument
  // naming max_objects (the object added is then left without a proxy);
  // bvh and our finders grow.  Our CPU finders search on `tasks`' threads,
  // which must outlive the broadphase.
  BroadphaseChoice make(std::string_view name, const btVector3& world_min,
                        const btVector3& world_max, int max_objects,
                        TaskSystem& tasks = defaultTaskSystem()) const;
  // What a btCollisionWorld should get: make()'s pair search, with its ray
  // and sweep queries (raycasts, CCD) answered by one shared tree (a
  // CcdQueryBroadphase, physics/broadphase/ccd_query_broadphase.h).  Our
  // finders and bf answer a query by visiting every proxy; through the tree
  // it costs O(log n) under every name, and a program that never queries
  // never builds it.
  WorldBroadphaseChoice makeWorld(std::string_view name, const btVector3& world_min,
                                  const btVector3& world_max, int max_objects,
                                  TaskSystem& tasks = defaultTaskSystem()) const;

 private:
  std::vector<finders::PairFinderRow> finders_;
  std::vector<BroadphaseInfo> entries_;
  std::vector<std::string_view> names_;
};

// The product's catalogue: Bullet's broadphases and finders::pairFinderTable().
const BroadphaseCatalogue& productCatalogue();

// The product catalogue's entries(), names() and info().
std::span<const BroadphaseInfo> broadphaseCatalogue();
std::span<const std::string_view> broadphaseNames();
const BroadphaseInfo& broadphaseInfo(std::string_view name);

// The product catalogue's make() and makeWorld().
BroadphaseChoice makeBroadphase(std::string_view name, const btVector3& world_min,
                                const btVector3& world_max, int max_objects,
                                TaskSystem& tasks = defaultTaskSystem());
WorldBroadphaseChoice makeWorldBroadphase(std::string_view name, const btVector3& world_min,
                                          const btVector3& world_max, int max_objects,
                                          TaskSystem& tasks = defaultTaskSystem());

}  // namespace overlap::physics
