// The CUDA events around a GPU finder's frame (nvcc only): one before the
// upload, one after it, one after the kernels and one after the last copy
// back, read as the upload, kernel and copy-back times of DeviceWork and, end
// to end, as lastSearchMs().
//
// Rules:
// - Two sets of events serve frames in turn, so the last finished frame's
//   stay readable (and are read only when asked, not by finish()) while the
//   next frame records into the other set: a caller that reads no stage time
//   pays no elapsed-time call.
// - Times are read only from a frame whose done event the finder waited
//   for; before the first such frame every time is 0.
// - Every record is counted in the caller's call counter (DeviceWork's api_calls).
#pragma once

#include <cuda_runtime.h>

#include <cstdint>

#include "gpu/cuda/cuda_check.h"

namespace overlap::finders {

class StageEvents {
 public:
  enum Stage { kStarted, kUploaded, kSearched, kDone, kStageCount };

  StageEvents() {
    for (auto& set : events_) {
      for (cudaEvent_t& event : set) CUDA_CHECK(cudaEventCreate(&event));
    }
  }
  // Events are destroyed after the work that records them: the owner
  // synchronizes its stream first.  Errors cannot be thrown here.
  ~StageEvents() {
    for (auto& set : events_) {
      for (cudaEvent_t event : set) cudaEventDestroy(event);
    }
  }
  StageEvents(const StageEvents&) = delete;
  StageEvents& operator=(const StageEvents&) = delete;

  // Starts recording a new frame into the set the last finished frame does not use.
  void beginFrame() { recording_ = finished_ < 0 ? 0 : 1 - finished_; }
  // Records `stage` of the frame being recorded on `stream`.
  void record(Stage stage, cudaStream_t stream, std::uint64_t& calls) {
    CUDA_CHECK_COUNTED(calls, cudaEventRecord(events_[recording_][stage], stream));
  }
  // Waits for the frame's done event; from here its times are readable.
  void waitDone(std::uint64_t& calls) {
    CUDA_CHECK_COUNTED(calls, cudaEventSynchronize(events_[recording_][kDone]));
    finished_ = recording_;
  }

  // Milliseconds between two stages of the last finished frame (0 before one).
  double ms(Stage from, Stage to) const {
    if (finished_ < 0) return 0;
    float elapsed = 0;
    CUDA_CHECK(cudaEventElapsedTime(&elapsed, events_[finished_][from], events_[finished_][to]));
    return elapsed;
  }

 private:
  cudaEvent_t events_[2][kStageCount] = {};
  int recording_ = 0;
  int finished_ = -1;  // the set of the last finished frame; -1: none yet
};

}  // namespace overlap::finders
