#include "physics/broadphase_factory.h"

#include <BulletCollision/BroadphaseCollision/btAxisSweep3.h>
#include <BulletCollision/BroadphaseCollision/btDbvtBroadphase.h>
#include <BulletCollision/BroadphaseCollision/btSimpleBroadphase.h>

#include <array>
#include <stdexcept>
#include <string>

#include "gpu/background_pair_finder.h"
#include "physics/pair_finder_broadphase.h"

namespace overlap::physics {
namespace {

constexpr std::array<std::string_view, 8> kNames = {"bf",    "sap",    "sap32", "bvh",
                                                    "cpubf", "cpusap", "gpubf", "gpubf-paper"};
// btAxisSweep3 stores handles in 16 bits and reserves a few for itself.
constexpr int kMaxSap16Objects = 32766;

// The fastest exact finder without a GPU: what gpubf and gpubf-paper run
// where there is no CUDA device.
constexpr std::string_view kGpuFallback = "cpusap";

// The CPU finders search on a worker thread, so the frame's CPU tasks can
// overlap them as they overlap the GPU's search.
std::unique_ptr<gpu::PairFinder> cpuFinder(gpu::PairFinderKind kind) {
  return std::make_unique<gpu::BackgroundPairFinder>(gpu::makePairFinder(kind));
}

}  // namespace

std::span<const std::string_view> broadphaseNames() {
  return kNames;
}

BroadphaseChoice makeBroadphase(std::string_view name, const btVector3& world_min,
                                const btVector3& world_max, int max_objects) {
  BroadphaseChoice choice;
  choice.name = std::string(name);
  if (name == "bf") {
    choice.broadphase = std::make_unique<btSimpleBroadphase>(max_objects);
  } else if (name == "sap") {
    if (max_objects >= kMaxSap16Objects) {
      throw std::invalid_argument("algo sap: holds at most " +
                                  std::to_string(kMaxSap16Objects - 1) + " objects, asked for " +
                                  std::to_string(max_objects) + "; use sap32");
    }
    // No ray-test tree of its own: PhysicsWorld answers every broadphase's
    // ray and sweep queries through one shared tree (ccd_query_broadphase.h).
    choice.broadphase = std::make_unique<btAxisSweep3>(
        world_min, world_max, static_cast<unsigned short>(max_objects + 1), nullptr, true);
  } else if (name == "sap32") {
    choice.broadphase = std::make_unique<bt32BitAxisSweep3>(
        world_min, world_max, static_cast<unsigned int>(max_objects + 1), nullptr, true);
  } else if (name == "bvh") {
    choice.broadphase = std::make_unique<btDbvtBroadphase>();
  } else if (name == "cpubf") {
    choice.broadphase =
        std::make_unique<PairFinderBroadphase>(cpuFinder(gpu::PairFinderKind::kCpuBruteForce));
  } else if (name == "cpusap") {
    choice.broadphase =
        std::make_unique<PairFinderBroadphase>(cpuFinder(gpu::PairFinderKind::kCpuSweepAndPrune));
  } else if (name == "gpubf" || name == "gpubf-paper") {
    std::string why;
    if (gpu::cudaDeviceAvailable(&why)) {
      choice.broadphase = std::make_unique<PairFinderBroadphase>(
          gpu::makePairFinder(name == "gpubf" ? gpu::PairFinderKind::kGpuBruteForce
                                              : gpu::PairFinderKind::kGpuBruteForcePaper));
    } else {
      choice = makeBroadphase(kGpuFallback, world_min, world_max, max_objects);
      choice.notice =
          "algo " + std::string(name) + ": " + why + "; running " + choice.name + " instead";
    }
  } else {
    throw std::invalid_argument("algo: unknown broadphase '" + std::string(name) + "'");
  }
  return choice;
}

}  // namespace overlap::physics
