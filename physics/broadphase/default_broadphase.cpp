#include "physics/broadphase/default_broadphase.h"

#include "gpu/pair_finder.h"
#include "physics/broadphase/broadphase_factory.h"

namespace overlap::physics {

DefaultBroadphase defaultBroadphase(std::size_t objects, bool cuda_device,
                                    std::string_view no_device_why) {
  const std::string boxes = std::to_string(objects) + " boxes";
  if (!cuda_device) {
    return {kDeviceFallback, "default broadphase " + std::string(kDeviceFallback) + " for " +
                                 boxes + ": no CUDA device (" + std::string(no_device_why) +
                                 "), and it is the fastest exact CPU finder"};
  }
  if (objects < kGpubfFrom) {
    return {"cpubf", "default broadphase cpubf for " + boxes + ": below " +
                         std::to_string(kGpubfFrom) +
                         " boxes a GPU round trip cannot beat CPU threads (H100, docs/DESIGN.md)"};
  }
  if (objects < kGpusapFrom) {
    return {"gpubf", "default broadphase gpubf for " + boxes + ": the fastest exact finder from " +
                         std::to_string(kGpubfFrom) + " to " + std::to_string(kGpusapFrom) +
                         " boxes (H100, docs/DESIGN.md)"};
  }
  return {"gpusap", "default broadphase gpusap for " + boxes + ": from " +
                        std::to_string(kGpusapFrom) +
                        " boxes a brute force loses to a sort and sweep (H100, docs/DESIGN.md)"};
}

DefaultBroadphase defaultBroadphaseHere(std::size_t objects) {
  std::string why;
  const bool device = finders::cudaDeviceAvailable(&why);
  return defaultBroadphase(objects, device, why);
}

}  // namespace overlap::physics
