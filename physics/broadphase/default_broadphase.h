// The broadphase a run gets when it names none: the fastest exact one for the
// scene's box count on this machine, by the one rule stated here.
//
// With a CUDA device: cpubf below kGpubfFrom boxes, gpubf up to kGpusapFrom,
// gpusap from there.  The crossovers are the H100's finder times, launch()
// to finish() on the host, on generated scene-4 streams
// (docs/results/gpu/h100/, docs/DESIGN.md "The default
// broadphase"): at 500 boxes cpubf (16 threads) and gpubf tie at 60 us, and
// below it a GPU round trip cannot win; gpubf beats gpusap at 10^4 (215 us
// against 364) and loses at 3*10^4 (2550 against 567), and a power law
// through each finder's two points crosses near 1.3*10^4.  Those were the
// single-axis gpusap's; the slab version's crossover awaits a GPU
// (docs/results/gpu_kernel_cost.md predicts it between the same two sizes).
// Without a device: cpusap, the fastest exact CPU finder (kDeviceFallback).
// Every name picked is exact (tests/physics/default_broadphase_test.cpp).
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace overlap::physics {

inline constexpr std::size_t kGpubfFrom = 500;
inline constexpr std::size_t kGpusapFrom = 13000;

struct DefaultBroadphase {
  std::string_view name;
  std::string reason;  // one line: which name, for how many boxes, and why
};

// `no_device_why` says why there is no device (cudaDeviceAvailable's reason);
// it is read only when `cuda_device` is false.
DefaultBroadphase defaultBroadphase(std::size_t objects, bool cuda_device,
                                    std::string_view no_device_why = {});

// The same rule on this machine: whether a CUDA device is present, and why not.
DefaultBroadphase defaultBroadphaseHere(std::size_t objects);

}  // namespace overlap::physics
