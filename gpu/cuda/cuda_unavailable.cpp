// The GPU entry points of a build without CUDA (OVERLAP_HAVE_CUDA=0): the
// project still builds and runs with the CPU finder, and asking for a GPU
// finder says why it cannot have one.
#include <stdexcept>

#include "gpu/cuda/gpu_pair_finders.h"

namespace overlap::finders {

namespace {
constexpr const char* kReason = "built without CUDA";
}

bool cudaDeviceAvailable(std::string* why) {
  if (why != nullptr) *why = kReason;
  return false;
}

std::string cudaDeviceName() {
  return {};
}

std::unique_ptr<PairFinder> makeGpuPairFinder() {
  throw std::runtime_error(std::string("gpubf: ") + kReason);
}

std::unique_ptr<PairFinder> makePaperGpuPairFinder() {
  throw std::runtime_error(std::string("gpubf-paper: ") + kReason);
}

std::unique_ptr<PairFinder> makeGpuSapPairFinder() {
  throw std::runtime_error(std::string("gpusap: ") + kReason);
}

}  // namespace overlap::finders
