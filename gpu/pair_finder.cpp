#include "gpu/pair_finder.h"

#include <limits>
#include <stdexcept>
#include <string>

#include "gpu/cpu/cpu_pair_finder.h"
#include "gpu/cpu/cpu_sap_pair_finder.h"
#include "gpu/cuda/gpu_pair_finders.h"

namespace overlap::finders {

std::unique_ptr<PairFinder> makePairFinder(PairFinderKind kind, int cpu_threads) {
  if (kind == PairFinderKind::kCpuBruteForce) return std::make_unique<CpuPairFinder>(cpu_threads);
  if (kind == PairFinderKind::kCpuSweepAndPrune) {
    return std::make_unique<CpuSapPairFinder>(cpu_threads);
  }
  std::string why;
  if (!cudaDeviceAvailable(&why)) {
    throw std::runtime_error("makePairFinder: the GPU pair finders need a CUDA device: " + why);
  }
  if (kind == PairFinderKind::kGpuSweepAndPrune) return makeGpuSapPairFinder();
  return kind == PairFinderKind::kGpuBruteForce ? makeGpuPairFinder() : makePaperGpuPairFinder();
}

std::uint32_t checkedSlotCount(std::string_view finder, std::uint32_t previous,
                               std::size_t objects) {
  const std::string name(finder);
  if (objects < previous) {
    throw std::runtime_error(name + ": slot count shrank from " + std::to_string(previous) +
                             " to " + std::to_string(objects));
  }
  if (objects > std::numeric_limits<std::uint32_t>::max()) {
    throw std::runtime_error(name + ": " + std::to_string(objects) +
                             " slots do not fit 32-bit slot indices");
  }
  return static_cast<std::uint32_t>(objects);
}

}  // namespace overlap::finders
