#include "gpu/pair_finder.h"

#include <stdexcept>
#include <string>

#include "gpu/cpu_pair_finder.h"
#include "gpu/gpu_pair_finders.h"

namespace overlap::gpu {

std::unique_ptr<PairFinder> makePairFinder(PairFinderKind kind, int cpu_threads) {
  if (kind == PairFinderKind::kCpuBruteForce) return std::make_unique<CpuPairFinder>(cpu_threads);
  std::string why;
  if (!cudaDeviceAvailable(&why)) {
    throw std::runtime_error("makePairFinder: the GPU pair finders need a CUDA device: " + why);
  }
  return kind == PairFinderKind::kGpuBruteForce ? makeGpuPairFinder() : makePaperGpuPairFinder();
}

}  // namespace overlap::gpu
