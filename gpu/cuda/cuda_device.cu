// cudaDeviceAvailable for CUDA builds: a device must exist, the driver must
// be new enough for this runtime, and the binary must hold code the device
// can run (SASS for CMAKE_CUDA_ARCHITECTURES, sm_75 to sm_90, and sm_90 PTX).  The emulation
// build (gpu/emulation/) compiles this file too and has one device.
#include <cuda_runtime.h>

#include <string>

#include "gpu/pair_finder.h"

namespace overlap::finders {
namespace {

// Never launched: asking for its attributes tells whether this binary has a
// kernel image for the current device.
__global__ void kernelImageProbe() {}

bool fail(std::string* why, const std::string& reason) {
  if (why != nullptr) *why = reason;
  return false;
}

std::string describe(cudaError_t error) {
  return std::string(cudaGetErrorName(error)) + ": " + cudaGetErrorString(error);
}

}  // namespace

bool cudaDeviceAvailable(std::string* why) {
  int device_count = 0;
  if (const cudaError_t error = cudaGetDeviceCount(&device_count); error != cudaSuccess) {
    return fail(why, "no usable CUDA driver or device (" + describe(error) + ")");
  }
  if (device_count == 0) return fail(why, "no CUDA device");
  int device = 0;
  if (const cudaError_t error = cudaGetDevice(&device); error != cudaSuccess) {
    return fail(why, "cannot select a CUDA device (" + describe(error) + ")");
  }
  cudaFuncAttributes attributes{};
  if (const cudaError_t error = cudaFuncGetAttributes(&attributes, kernelImageProbe);
      error != cudaSuccess) {
    cudaDeviceProp properties{};
    const std::string name = cudaGetDeviceProperties(&properties, device) == cudaSuccess
                                 ? std::string(properties.name) + " (sm_" +
                                       std::to_string(properties.major) +
                                       std::to_string(properties.minor) + ")"
                                 : "device " + std::to_string(device);
    return fail(why, name + " cannot run this build's kernels (" + describe(error) + ")");
  }
  if (why != nullptr) why->clear();
  return true;
}

std::string cudaDeviceName() {
  int device = 0;
  cudaDeviceProp properties{};
  if (!cudaDeviceAvailable(nullptr) || cudaGetDevice(&device) != cudaSuccess ||
      cudaGetDeviceProperties(&properties, device) != cudaSuccess) {
    return {};
  }
#if defined(OVERLAP_CUDA_EMULATION)
  return properties.name;  // "CUDA emulation on the CPU, N threads": no SM to name
#endif
  return std::string(properties.name) + " (sm_" + std::to_string(properties.major) +
         std::to_string(properties.minor) + ", " + std::to_string(properties.multiProcessorCount) +
         " SMs)";
}

}  // namespace overlap::finders
