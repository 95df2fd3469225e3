// FinderDevice: the device side of a GPU finder, which lives as long as the
// finder, across all its frames; one helper for gpubf, gpubf-paper and gpusap
// (nvcc and the emulation only): the stream, the stage events, the pinned
// staging of the boxes, the counted and checked CUDA call, and the CUDA
// graphs that replay a frame's fixed chain.
//
// Rules, each with its reason:
// - Every runtime call a frame makes goes through check() (or a helper here
//   that calls it), so DeviceWork::api_calls counts them all, and an error
//   names the caller's file and line (std::source_location), not this file.
// - Stage events: two sets serve frames in turn, so the last finished
//   frame's stay readable (lastWorkTimed(), lastMs(): read only when asked,
//   never by finish(), in every finder) while the next frame records into
//   the other set.  Times are read only from a frame end() closed; before
//   one every time is 0.
// - Staging: pinned, so the upload is asynchronous; room() lends it to the
//   caller between frames only (a search in flight may still read it), and
//   stage() copies the caller's pageable boxes into it otherwise.  It grows
//   geometrically and never shrinks.
// - Graphs: enqueueChain() runs a frame's fixed chain (no host wait inside)
//   as a CUDA graph.  The key names every value the chain bakes in (sizes,
//   pointers, parities); a chain whose key matches one of the last two
//   captured is one cudaGraphLaunch, else it is captured anew (allocations
//   must come before: a capture refuses them).  Two, as a steady frame's
//   buffers and events alternate between two roles.  A replay counts the
//   bytes its copies move, as the capture did, and one call.
// - Everything it holds is an owning handle (gpu/cuda/cuda_handles.h,
//   cuda_buffers.h), so a throw in the constructor leaves nothing behind; the
//   stream, declared last, goes first and waits for its work before the
//   events, graphs and staging it uses go.
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <source_location>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "gpu/cuda/cuda_buffers.h"
#include "gpu/cuda/cuda_check.h"
#include "gpu/cuda/cuda_handles.h"
#include "gpu/pair_finder.h"

namespace overlap::finders {

class FinderDevice {
 public:
  using Where = std::source_location;
  // kTailsDone: after a second copy back, where a finder makes one.
  enum Stage { kStarted, kUploaded, kSearched, kDone, kTailsDone, kStageCount };
  // kLegacyDefault: the default stream, as gpubf-paper's paper has it.
  enum class StreamKind { kOwn, kLegacyDefault };

  explicit FinderDevice(StreamKind kind = StreamKind::kOwn) {
    for (auto& set : events_) {
      for (Event& event : set) event = makeEvent();
    }
    stream_ = kind == StreamKind::kOwn ? makeNonBlockingStream() : legacyDefaultStream();
  }

  cudaStream_t stream() const { return stream_.get(); }

  // --- the frame's counts and events ---------------------------------------
  // A new frame: its counts start at zero and its events go to the set the
  // last finished frame does not use.
  void begin() {
    work_ = DeviceWork{};
    recording_ = finished_ < 0 ? 0 : 1 - finished_;
    tails_recorded_[recording_] = false;
  }
  DeviceWork& work() { return work_; }
  // The frame is finished: its counts and times become the last finished frame's.
  void end() {
    last_work_ = work_;
    finished_ = recording_;
  }
  const DeviceWork& lastWork() const { return last_work_; }
  // ... with the stage times read from its events, added to what the finder
  // noted itself (a search it ran twice): upload kStarted to kUploaded,
  // kernels to kSearched, copy back to kDone, and kDone to kTailsDone where
  // the frame recorded it.
  DeviceWork lastWorkTimed() const {
    DeviceWork work = last_work_;
    work.upload_ms += lastMs(kStarted, kUploaded);
    work.kernels_ms += lastMs(kUploaded, kSearched);
    work.download_ms += lastMs(kSearched, kDone);
    if (finished_ >= 0 && tails_recorded_[finished_]) work.download_ms += lastMs(kDone, kTailsDone);
    return work;
  }
  // Milliseconds between two stages of the last finished frame (0 before one).
  double lastMs(Stage from, Stage to) const {
    if (finished_ < 0) return 0;
    float elapsed = 0;
    CUDA_CHECK(cudaEventElapsedTime(&elapsed, events_[finished_][from].get(),
                                    events_[finished_][to].get()));
    return elapsed;
  }

  // --- counted, checked calls ----------------------------------------------
  void check(cudaError_t status, const char* what, Where where = Where::current()) {
    ++work_.api_calls;
    checkCuda(status, what, where);
  }
  // After a kernel launch: the launch counted, its errors checked.
  void launched(Where where = Where::current()) {
    ++work_.api_calls;
    check(cudaGetLastError(), "a kernel launch", where);
  }
  // Records `stage` of this frame on the stream (into the graph, when capturing).
  void record(Stage stage, Where where = Where::current()) {
    const cudaEvent_t event = events_[recording_][stage].get();
    if (stage == kTailsDone) tails_recorded_[recording_] = true;
    if (capturing_) {
      check(cudaEventRecordWithFlags(event, stream(), cudaEventRecordExternal),
            "cudaEventRecordWithFlags", where);
    } else {
      check(cudaEventRecord(event, stream()), "cudaEventRecord", where);
    }
  }
  void wait(Stage stage, Where where = Where::current()) {
    check(cudaEventSynchronize(events_[recording_][stage].get()), "cudaEventSynchronize", where);
  }
  // Milliseconds between two stages of this frame, which the caller waited for.
  float elapsed(Stage from, Stage to, Where where = Where::current()) {
    float ms = 0;
    check(cudaEventElapsedTime(&ms, events_[recording_][from].get(), events_[recording_][to].get()),
          "cudaEventElapsedTime", where);
    return ms;
  }
  // The staged boxes to `to` on the device, asynchronously; none: no call.
  void upload(ObjectBounds* to, std::size_t count, Where where = Where::current()) {
    if (count == 0) return;
    check(cudaMemcpyAsync(to, staging_.data(), count * sizeof(ObjectBounds), cudaMemcpyHostToDevice,
                          stream()),
          "cudaMemcpyAsync", where);
    work_.bytes_to_device += count * sizeof(ObjectBounds);
  }
  // `bytes` from the device to pinned `to`, asynchronously; none: no call.
  void download(void* to, const void* from, std::size_t bytes, Where where = Where::current()) {
    if (bytes == 0) return;
    check(cudaMemcpyAsync(to, from, bytes, cudaMemcpyDeviceToHost, stream()), "cudaMemcpyAsync",
          where);
    work_.bytes_from_device += bytes;
  }

  // The list of `count` entries whose first ones came back in a result
  // block, `in_head` (gpu/cuda/launch_shape.h), and whose rest is on the
  // device at `rest`: `in_head` itself when it holds them all, else `host`
  // filled with both, the rest's copy queued (the caller waits).
  IndexPair* joinHeadAndRest(std::span<IndexPair> in_head, std::size_t count, const IndexPair* rest,
                             PinnedBuffer<IndexPair>& host, Where where = Where::current()) {
    if (count <= in_head.size()) return in_head.data();
    reserveDiscarding(host, count);
    std::memcpy(host.data(), in_head.data(), in_head.size_bytes());
    work_.host_bytes_copied += in_head.size_bytes();
    download(host.data() + in_head.size(), rest, (count - in_head.size()) * sizeof(IndexPair),
             where);
    return host.data();
  }

  // --- pinned staging --------------------------------------------------------
  // PairFinder::stagingFor(): room for `count` boxes, lent only between
  // frames (the base class checks).
  std::span<ObjectBounds> stagingRoom(std::size_t count) {
    reserveDiscarding(staging_, count);
    return {staging_.data(), count};
  }
  // Makes `objects` this frame's staged boxes: nothing to do when the caller
  // filled stagingRoom(), else a host copy (counted in host_bytes_copied),
  // as the caller's memory may change once launch() returns.
  void stage(std::span<const ObjectBounds> objects) {
    if (objects.empty() || objects.data() == staging_.data()) return;
    reserveDiscarding(staging_, objects.size());
    std::memcpy(staging_.data(), objects.data(), objects.size_bytes());
    work_.host_bytes_copied += objects.size_bytes();
  }
  const ObjectBounds* staged() const { return staging_.data(); }

  // --- graphs ----------------------------------------------------------------
  // Runs enqueue() (calls on stream() and this helper only, no wait, no
  // allocation) as a graph: replayed when `key` and the event set match a
  // captured one, else captured anew.  The staging's address is part of the key.
  template <class Enqueue>
  void enqueueChain(std::vector<std::uintptr_t> key, Enqueue enqueue,
                    Where where = Where::current()) {
    key.push_back(static_cast<std::uintptr_t>(recording_));
    key.push_back(reinterpret_cast<std::uintptr_t>(staging_.data()));
    for (const Chain& chain : chains_) {
      if (chain.exec && chain.key == key) {
        check(cudaGraphLaunch(chain.exec.get(), stream()), "cudaGraphLaunch", where);
        work_.bytes_to_device += chain.bytes_to_device;
        work_.bytes_from_device += chain.bytes_from_device;
        return;
      }
    }
    Chain& slot = chains_[next_chain_];
    next_chain_ = 1 - next_chain_;
    if (slot.exec) {
      check(cudaGraphExecDestroy(slot.exec.release()), "cudaGraphExecDestroy", where);
      slot = Chain{};
    }
    check(cudaStreamBeginCapture(stream(), cudaStreamCaptureModeThreadLocal),
          "cudaStreamBeginCapture", where);
    capturing_ = true;
    const DeviceWork before = work_;
    cudaGraph_t captured = nullptr;
    try {
      enqueue();
    } catch (...) {
      capturing_ = false;
      if (cudaStreamEndCapture(stream(), &captured) == cudaSuccess) cudaGraphDestroy(captured);
      throw;
    }
    capturing_ = false;
    check(cudaStreamEndCapture(stream(), &captured), "cudaStreamEndCapture", where);
    Graph graph(captured);
    cudaGraphExec_t exec = nullptr;
    const cudaError_t instantiated = cudaGraphInstantiate(&exec, graph.get(), 0);
    GraphExec owned = instantiated == cudaSuccess ? GraphExec(exec) : GraphExec();
    check(cudaGraphDestroy(graph.release()), "cudaGraphDestroy", where);
    check(instantiated, "cudaGraphInstantiate", where);
    slot = Chain{std::move(key), std::move(owned), work_.bytes_to_device - before.bytes_to_device,
                 work_.bytes_from_device - before.bytes_from_device};
    check(cudaGraphLaunch(slot.exec.get(), stream()), "cudaGraphLaunch", where);
  }

 private:
  struct Chain {
    std::vector<std::uintptr_t> key;
    GraphExec exec;
    std::uint64_t bytes_to_device = 0;  // what its copies move
    std::uint64_t bytes_from_device = 0;
  };

  Event events_[2][kStageCount];
  int recording_ = 0;
  int finished_ = -1;                        // the set of the last finished frame; -1: none yet
  bool tails_recorded_[2] = {false, false};  // whether the set's frame recorded kTailsDone
  DeviceWork work_;                          // the frame in flight's counts
  DeviceWork last_work_;
  PinnedBuffer<ObjectBounds> staging_;
  Chain chains_[2];
  int next_chain_ = 0;  // the slot the next capture replaces
  bool capturing_ = false;
  Stream stream_;  // last, so that it goes first: it waits for the work using the rest
};

}  // namespace overlap::finders
