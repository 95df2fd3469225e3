// The end of a GPU finder's frame, one rule for every GPU finder (nvcc and
// the emulation only).
//
// Rules, each with its reason:
// - finish() pairs with a launch(): a second finish() has no search to wait
//   for, so it throws naming the finder.
// - The frame ends whether collecting its changes returns or throws: the
//   caller may launch again either way.
// - On a return, `launch_to_finish_ms` is the host's time since launch()
//   (PairFinder::lastLaunchToFinishMs), read after the changes are in hand.
// - After a throw no work of the frame stays queued on the finder's stream,
//   so nothing it enqueued can write into buffers the caller reuses; the
//   stream's own error is the one being thrown, so the wait's is dropped.
#pragma once

#include <cuda_runtime.h>

#include <stdexcept>
#include <string>
#include <string_view>

#include "gpu/base/stopwatch.h"
#include "gpu/pair_finder.h"

namespace overlap::finders {

template <class Collect>
PairDelta finishFrame(std::string_view finder, bool& in_flight, cudaStream_t stream,
                      const HostStopwatch& since_launch, double& launch_to_finish_ms,
                      Collect collect) {
  if (!in_flight)
    throw std::runtime_error(std::string(finder) + ": finish() called without launch()");
  in_flight = false;
  try {
    const PairDelta delta = collect();
    launch_to_finish_ms = since_launch.ms();
    return delta;
  } catch (...) {
    cudaStreamSynchronize(stream);
    throw;
  }
}

}  // namespace overlap::finders
