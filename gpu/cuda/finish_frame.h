// The end of a GPU finder's frame, one rule for every GPU finder (nvcc and
// the emulation only).
//
// PairFinder::finish() keeps the order of the calls and the clock; this is
// what is left to a GPU finder's finishSearch():
// - After a throw no work of the frame stays queued on the finder's stream,
//   so nothing it enqueued can write into buffers the caller reuses; the
//   stream's own error is the one being thrown, so the wait's is dropped.
#pragma once

#include <cuda_runtime.h>

#include "gpu/pair_finder.h"

namespace overlap::finders {

template <class Collect>
PairDelta finishFrame(cudaStream_t stream, Collect collect) {
  try {
    return collect();
  } catch (...) {
    cudaStreamSynchronize(stream);
    throw;
  }
}

}  // namespace overlap::finders
