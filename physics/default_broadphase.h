// The broadphase a run gets when it names none: the fastest exact one for the
// scene's box count on this machine, by the one rule stated here.
//
// With a CUDA device: cpubf below kGpubfFrom boxes, gpubf up to kGpusapFrom,
// gpusap from there.  Reasons, from the H200 figures (docs/DESIGN.md, "The
// default broadphase"): gpubf's fixed cost (an upload, a launch, one copy
// back) loses to cpubf's threads on the fewest boxes, and its n²/2 tests lose
// to a sort-and-sweep past some tens of thousands.  gpusap's crossover is the
// H200's brute-force limit; the H100 measured gpusap ahead of gpubf from
// between 10^4 and 3*10^4 boxes (docs/results/gpu/h100/), not yet narrowed.
// Without a device: cpusap, the fastest exact CPU finder (kDeviceFallback).
// Every name picked is exact (tests/physics/default_broadphase_test.cpp).
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace overlap::physics {

inline constexpr std::size_t kGpubfFrom = 500;
inline constexpr std::size_t kGpusapFrom = 50000;

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
