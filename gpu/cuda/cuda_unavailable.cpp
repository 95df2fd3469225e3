// The GPU entry points of a build without CUDA (OVERLAP_HAVE_CUDA=0): the
// project still builds and runs with the CPU finders, and asking for a GPU
// finder says why it cannot have one (makePairFinder asks
// cudaDeviceAvailable() first).
#include <string>

#include "gpu/pair_finder.h"

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

}  // namespace overlap::finders
