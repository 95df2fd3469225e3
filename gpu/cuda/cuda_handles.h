// Owning handles for CUDA's streams, events and graphs (nvcc and the
// emulation only), as gpu/cuda/cuda_buffers.h owns memory: each handle
// releases what it holds when it goes, moves but never copies, and is made
// by a function that throws (checkCuda()) rather than hand back a handle
// that holds nothing.  A class composed of handles needs no destructor of
// its own, and a throw between two creations releases what the first made.
//
// Rules, each with its reason:
// - Release cannot report an error from a destructor; a failure there means
//   the context is already lost, which the next checked call reports.
// - A Stream waits for the work queued on it before it goes, so that nothing
//   queued outlives the memory it uses: a class declares its Stream last, so
//   that it goes first.  A Stream may hold the legacy default stream (null),
//   which it waits for and never destroys.
// - Events and graph executables that queued work still uses are released by
//   CUDA once that work is done, as its documentation promises.
#pragma once

#include <cuda_runtime.h>

#include <source_location>
#include <utility>

#include "gpu/cuda/cuda_check.h"

namespace overlap::finders {

template <class Handle, class Release>
class CudaHandle {
 public:
  CudaHandle() = default;
  // Takes ownership of `handle` (for a Stream, null: the legacy default stream).
  explicit CudaHandle(Handle handle) : handle_(handle), owned_(true) {}
  CudaHandle(CudaHandle&& other) noexcept
      : handle_(std::exchange(other.handle_, Handle{})),
        owned_(std::exchange(other.owned_, false)) {}
  // Releases what this handle held, then takes `other`'s (never a swap).
  CudaHandle& operator=(CudaHandle&& other) noexcept {
    if (this != &other) {
      reset();
      handle_ = std::exchange(other.handle_, Handle{});
      owned_ = std::exchange(other.owned_, false);
    }
    return *this;
  }
  CudaHandle(const CudaHandle&) = delete;
  CudaHandle& operator=(const CudaHandle&) = delete;
  ~CudaHandle() { reset(); }

  Handle get() const { return handle_; }
  explicit operator bool() const { return owned_; }
  // Gives up ownership: the caller releases the handle (through a counted call).
  Handle release() noexcept {
    owned_ = false;
    return std::exchange(handle_, Handle{});
  }
  void reset() noexcept {
    if (owned_) Release{}(handle_);
    handle_ = Handle{};
    owned_ = false;
  }

 private:
  Handle handle_{};
  bool owned_ = false;
};

struct StreamRelease {
  void operator()(cudaStream_t stream) const noexcept {
    cudaStreamSynchronize(stream);
    if (stream != nullptr) cudaStreamDestroy(stream);
  }
};
struct EventRelease {
  void operator()(cudaEvent_t event) const noexcept { cudaEventDestroy(event); }
};
struct GraphRelease {
  void operator()(cudaGraph_t graph) const noexcept { cudaGraphDestroy(graph); }
};
struct GraphExecRelease {
  void operator()(cudaGraphExec_t exec) const noexcept { cudaGraphExecDestroy(exec); }
};

using Stream = CudaHandle<cudaStream_t, StreamRelease>;
using Event = CudaHandle<cudaEvent_t, EventRelease>;
using Graph = CudaHandle<cudaGraph_t, GraphRelease>;
using GraphExec = CudaHandle<cudaGraphExec_t, GraphExecRelease>;

// A new stream that does not synchronize with the legacy default stream.
inline Stream makeNonBlockingStream(std::source_location where = std::source_location::current()) {
  cudaStream_t stream = nullptr;
  checkCuda(cudaStreamCreateWithFlags(&stream, cudaStreamNonBlocking), "cudaStreamCreateWithFlags",
            where);
  return Stream(stream);
}

// The legacy default stream, waited for when the handle goes.
inline Stream legacyDefaultStream() {
  return Stream(nullptr);
}

inline Event makeEvent(std::source_location where = std::source_location::current()) {
  cudaEvent_t event = nullptr;
  checkCuda(cudaEventCreate(&event), "cudaEventCreate", where);
  return Event(event);
}

}  // namespace overlap::finders
