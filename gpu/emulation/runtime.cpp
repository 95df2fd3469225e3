// The CUDA emulation's runtime API: one device, memory, streams and events.
//
// Memory: device and pinned allocations are host memory from posix_memalign
// (so AddressSanitizer guards them), filled with kGarbage at allocation and
// again at free.  A table of the live allocations checks every copy, memset,
// free and kernel pointer argument; a violation aborts naming the call site.
//
// Streams are lazy.  Each holds a queue of operations; an operation runs only
// when the host waits for it (a synchronize, a blocking copy, cudaFree's
// implicit synchronization), after the operations it depends on: those
// before it on its stream, and for the legacy default stream and blocking
// streams, each other's earlier work, as CUDA orders them.  Work enqueued and
// never waited for does not run, so a missing synchronization reads garbage.
// One mutex serializes the API: the emulated device runs one thing at a time.
//
// Graphs: while a stream captures, each copy, memset, launch and external
// event record enqueued on it is checked as usual and kept, as a node, instead
// of enqueued; a launched graph enqueues its nodes on the launch's stream in
// capture order, each checked and counted again as if called then (the
// launch itself is the one API call).  Calls a GPU refuses while capturing
// spoil the capture (cudaStreamEndCapture then fails): see cuda_runtime.h.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <functional>
#include <iterator>
#include <map>
#include <mutex>
#include <new>
#include <set>
#include <utility>
#include <vector>

#include "gpu/emulation/api_counters.h"
#include "gpu/emulation/executor.h"

struct CudaEmulationGraph;

struct CudaEmulationStream {
  struct Operation {
    std::function<void()> run;
    std::vector<std::pair<CudaEmulationStream*, std::uint64_t>> after;  // (stream, sequence)
  };
  bool blocking = true;  // synchronizes with the legacy default stream
  std::deque<Operation> pending;
  std::uint64_t enqueued = 0;             // sequence number of the last operation enqueued
  std::uint64_t completed = 0;            // ... and of the last one run
  CudaEmulationGraph* capture = nullptr;  // the graph being captured, if capturing
  bool capture_spoiled = false;
};

// A node enqueues its work, checked and counted, on the stream it is given.
struct CudaEmulationGraph {
  std::vector<std::function<void(CudaEmulationStream&)>> nodes;
};

struct CudaEmulationGraphExec {
  std::vector<std::function<void(CudaEmulationStream&)>> nodes;
};

struct CudaEmulationEvent {
  bool timing = true;
  CudaEmulationStream* stream = nullptr;  // where it was last recorded
  std::uint64_t sequence = 0;
  bool recorded = false;
  std::chrono::steady_clock::time_point when;
};

namespace overlap::cuda_emulation::detail {
namespace {

constexpr unsigned char kGarbage = 0xA5;
constexpr std::size_t kAlignment = 256;  // cudaMalloc's guarantee
constexpr std::size_t kMaxSharedBytesPerBlock = 48 * 1024;

thread_local cudaError_t t_last_error = cudaSuccess;
// The stream this thread captures, if any.
thread_local CudaEmulationStream* t_capturing = nullptr;

cudaError_t record(cudaError_t error) {
  if (error != cudaSuccess) t_last_error = error;
  return error;
}

// A call a GPU refuses while `target` captures: it spoils the capture.
cudaError_t refuseWhileCapturing(CudaEmulationStream& target) {
  target.capture_spoiled = true;
  return record(cudaErrorStreamCaptureUnsupported);
}

// Memory calls and device-wide waits are refused while this thread captures.
bool refusedWhileThisThreadCaptures(cudaError_t& error) {
  if (t_capturing == nullptr) return false;
  error = refuseWhileCapturing(*t_capturing);
  return true;
}

// The counts of gpu/emulation/api_counters.h, under their own mutex: some
// calls count before they take the runtime's.
std::mutex g_counters_mutex;
ApiCounters g_counters;

template <class Field>
void count(Field ApiCounters::*field, std::uint64_t amount = 1) {
  const std::lock_guard lock(g_counters_mutex);
  g_counters.*field += amount;
}

void countCall() {
  count(&ApiCounters::api_calls);
}

enum class Space { kDevice, kPinned };

struct Allocation {
  std::size_t bytes;
  Space space;
  std::source_location site;
};

const char* spaceName(Space space) {
  return space == Space::kDevice ? "device" : "pinned host";
}

class Runtime {
 public:
  std::mutex mutex;

  // --- memory --------------------------------------------------------------
  cudaError_t allocate(void** pointer, std::size_t bytes, Space space,
                       const std::source_location& site) {
    if (pointer == nullptr) return cudaErrorInvalidValue;
    *pointer = nullptr;
    if (bytes == 0) return cudaSuccess;
    void* memory = nullptr;
    if (posix_memalign(&memory, kAlignment, bytes) != 0) return cudaErrorMemoryAllocation;
    std::memset(memory, kGarbage, bytes);
    allocations_.emplace(address(memory), Allocation{bytes, space, site});
    *pointer = memory;
    return cudaSuccess;
  }

  cudaError_t release(void* pointer, Space space, const char* call,
                      const std::source_location& site) {
    if (pointer == nullptr) return cudaSuccess;
    synchronizeAll();  // cudaFree and cudaFreeHost synchronize the device
    const auto found = allocations_.find(address(pointer));
    if (found == allocations_.end() || found->second.space != space) {
      fail(std::string(call) + " at " + where(site) + ": " + describe(pointer) + " is not a live " +
           spaceName(space) + " allocation");
    }
    std::memset(pointer, kGarbage, found->second.bytes);
    allocations_.erase(found);
    std::free(pointer);
    return waited();
  }

  // The allocation [pointer, pointer + bytes) lies in, if any; aborts when it
  // starts in one and runs past its end.
  const Allocation* checkRange(const void* pointer, std::size_t bytes, const char* call,
                               const char* role, const std::source_location& site) const {
    const auto [base, allocation] = containing(pointer);
    if (allocation == nullptr) return nullptr;
    const std::uintptr_t offset = address(pointer) - base;
    if (offset + bytes > allocation->bytes) {
      fail(std::string(call) + " at " + where(site) + ": the " + role + " range of " +
           std::to_string(bytes) + " bytes at offset " + std::to_string(offset) +
           " runs past the end of a " + spaceName(allocation->space) + " allocation of " +
           std::to_string(allocation->bytes) + " bytes made at " + where(allocation->site));
    }
    return allocation;
  }

  // A copy's or memset's pointer: device memory where `device` says so,
  // otherwise host memory (pinned, checked, or pageable, not checkable).
  void checkOperand(const void* pointer, std::size_t bytes, bool device, const char* call,
                    const char* role, const std::source_location& site) const {
    if (bytes == 0) return;
    const Allocation* allocation = checkRange(pointer, bytes, call, role, site);
    const bool is_device = allocation != nullptr && allocation->space == Space::kDevice;
    if (device && !is_device) {
      fail(std::string(call) + " at " + where(site) + ": the " + role + " " + describe(pointer) +
           " is not in a live device allocation");
    }
    if (!device && is_device) {
      fail(std::string(call) + " at " + where(site) + ": the " + role + " " + describe(pointer) +
           " is device memory where the copy's kind says host");
    }
  }

  // Every pointer argument of `launch` is null or in a live allocation.
  void checkKernelArguments(const KernelLaunch& launch) {
    for (std::size_t position = 0; position < launch.pointer_arguments.size(); ++position) {
      const void* pointer = launch.pointer_arguments[position];
      if (pointer == nullptr) continue;
      const auto [base, allocation] = containing(pointer);
      if (allocation == nullptr || address(pointer) - base > allocation->bytes) {
        fail("kernel " + std::string(launch.kernel_name) + " launched at " + where(launch.site) +
             ": pointer argument " + std::to_string(position + 1) + " (" + describe(pointer) +
             ") is not in a live device or pinned allocation");
      }
    }
  }

  std::uint64_t liveBytes(Space space) const {
    std::uint64_t bytes = 0;
    for (const auto& [base, allocation] : allocations_) {
      if (allocation.space == space) bytes += allocation.bytes;
    }
    return bytes;
  }

  bool onDevice(const void* pointer) const {
    const Allocation* allocation = containing(pointer).second;
    return allocation != nullptr && allocation->space == Space::kDevice;
  }

  // --- streams -------------------------------------------------------------
  CudaEmulationStream* stream(cudaStream_t handle) {
    if (handle == nullptr) return &legacy_;
    return streams_.count(handle) != 0 ? handle : nullptr;
  }

  CudaEmulationStream* createStream(bool blocking) {
    auto* created = new CudaEmulationStream;
    created->blocking = blocking;
    streams_.insert(created);
    return created;
  }

  void destroyStream(CudaEmulationStream* doomed) {
    runUntil(*doomed, doomed->enqueued);  // its work still completes, as on a GPU
    for (CudaEmulationEvent* event : events_) {
      if (event->stream == doomed) event->stream = nullptr;
    }
    streams_.erase(doomed);
    delete doomed;
  }

  // Returns the operation's sequence number on `target`.
  std::uint64_t enqueue(CudaEmulationStream& target, std::function<void()> run,
                        std::vector<std::pair<CudaEmulationStream*, std::uint64_t>> after = {}) {
    if (&target == &legacy_) {
      for (CudaEmulationStream* other : streams_) {
        if (other->blocking) after.emplace_back(other, other->enqueued);
      }
    } else if (target.blocking) {
      after.emplace_back(&legacy_, legacy_.enqueued);
    }
    target.pending.push_back({std::move(run), std::move(after)});
    return ++target.enqueued;
  }

  void runUntil(CudaEmulationStream& target, std::uint64_t sequence) {
    while (target.completed < sequence) {
      CudaEmulationStream::Operation operation = std::move(target.pending.front());
      target.pending.pop_front();
      ++target.completed;  // counted before it runs: whatever it throws, it is done
      try {
        for (const auto& [other, other_sequence] : operation.after) {
          runUntil(*other, other_sequence);
        }
        operation.run();
      } catch (const std::bad_alloc&) {
        // The emulation's own memory ran out running it (a grid's block
        // runners, say): the call that waited returns the error.
        if (deferred_ == cudaSuccess) deferred_ = cudaErrorMemoryAllocation;
      }
    }
  }

  // The error of the work the running call waited for, once (runUntil never
  // throws: CUDA's calls return their errors, and cudaFree runs in destructors).
  cudaError_t waited() { return std::exchange(deferred_, cudaSuccess); }

  void synchronizeAll() {
    runUntil(legacy_, legacy_.enqueued);
    for (CudaEmulationStream* each : streams_) runUntil(*each, each->enqueued);
  }

  // --- handles -------------------------------------------------------------
  // Whether this creation is the one failHandleCreation() asked to fail.
  bool creationFails() {
    if (fail_creation_in_ == 0) return false;
    return --fail_creation_in_ == 0;
  }
  void failCreation(std::uint64_t nth) { fail_creation_in_ = nth; }
  LiveHandles liveHandles() const {
    return LiveHandles{streams_.size(), events_.size(), graphs_.size(), execs_.size()};
  }

  // --- events --------------------------------------------------------------
  bool known(cudaEvent_t event) const { return events_.count(event) != 0; }
  void add(cudaEvent_t event) { events_.insert(event); }
  void remove(cudaEvent_t event) { events_.erase(event); }

  // --- graphs --------------------------------------------------------------
  bool known(cudaGraph_t graph) const { return graphs_.count(graph) != 0; }
  bool known(cudaGraphExec_t exec) const { return execs_.count(exec) != 0; }
  void add(cudaGraph_t graph) { graphs_.insert(graph); }
  void add(cudaGraphExec_t exec) { execs_.insert(exec); }
  void remove(cudaGraph_t graph) { graphs_.erase(graph); }
  void remove(cudaGraphExec_t exec) { execs_.erase(exec); }

 private:
  static std::uintptr_t address(const void* pointer) {
    return reinterpret_cast<std::uintptr_t>(pointer);
  }

  static std::string describe(const void* pointer) {
    char text[32];
    std::snprintf(text, sizeof text, "%p", pointer);
    return text;
  }

  std::pair<std::uintptr_t, const Allocation*> containing(const void* pointer) const {
    auto after = allocations_.upper_bound(address(pointer));
    if (after == allocations_.begin()) return {0, nullptr};
    const auto& [base, allocation] = *std::prev(after);
    // One past the end still belongs to it (an empty range there is legal).
    if (address(pointer) - base > allocation.bytes) return {0, nullptr};
    return {base, &allocation};
  }

  std::map<std::uintptr_t, Allocation> allocations_;
  CudaEmulationStream legacy_;
  std::set<CudaEmulationStream*> streams_;
  std::set<CudaEmulationEvent*> events_;
  std::set<CudaEmulationGraph*> graphs_;
  std::set<CudaEmulationGraphExec*> execs_;
  std::uint64_t fail_creation_in_ = 0;  // creations until the injected failure; 0: none
  cudaError_t deferred_ = cudaSuccess;  // of the work run since the last waited()
};

Runtime& runtime() {
  static Runtime instance;
  return instance;
}

bool validDims(const dim3& dims, unsigned max_x, unsigned max_y, unsigned max_z) {
  return dims.x >= 1 && dims.y >= 1 && dims.z >= 1 && dims.x <= max_x && dims.y <= max_y &&
         dims.z <= max_z;
}

void countCopy(bool to_device, bool from_device, std::size_t bytes, bool blocking) {
  if (blocking) count(&ApiCounters::host_waits);
  if (to_device && from_device) {
    count(&ApiCounters::copies_on_device);
  } else if (to_device) {
    count(&ApiCounters::copies_to_device);
    count(&ApiCounters::bytes_to_device, bytes);
  } else if (from_device) {
    count(&ApiCounters::copies_to_host);
    count(&ApiCounters::bytes_to_host, bytes);
  }
}

void checkCopy(Runtime& rt, void* to, const void* from, std::size_t bytes, cudaMemcpyKind kind,
               const char* call, const std::source_location& site) {
  if (kind == cudaMemcpyDefault) {
    // Unified addressing: the table knows which side each pointer is on.
    rt.checkRange(to, bytes, call, "destination", site);
    rt.checkRange(from, bytes, call, "source", site);
  } else {
    rt.checkOperand(to, bytes, kind == cudaMemcpyHostToDevice || kind == cudaMemcpyDeviceToDevice,
                    call, "destination", site);
    rt.checkOperand(from, bytes, kind == cudaMemcpyDeviceToHost || kind == cudaMemcpyDeviceToDevice,
                    call, "source", site);
  }
}

// A checked, counted copy enqueued on `target` (and waited for if blocking).
void copyOn(Runtime& rt, CudaEmulationStream& target, void* to, const void* from, std::size_t bytes,
            cudaMemcpyKind kind, bool blocking, const char* call,
            const std::source_location& site) {
  checkCopy(rt, to, from, bytes, kind, call, site);
  countCopy(rt.onDevice(to), rt.onDevice(from), bytes, blocking);
  const std::uint64_t sequence = rt.enqueue(target, [=] {
    if (bytes != 0) std::memmove(to, from, bytes);
  });
  if (blocking) rt.runUntil(target, sequence);
}

cudaError_t copy(void* to, const void* from, std::size_t bytes, cudaMemcpyKind kind,
                 cudaStream_t handle, bool blocking, const char* call,
                 const std::source_location& site) {
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  CudaEmulationStream* target = rt.stream(handle);
  if (target == nullptr) return record(cudaErrorInvalidResourceHandle);
  if (kind < cudaMemcpyHostToHost || kind > cudaMemcpyDefault) return record(cudaErrorInvalidValue);
  if (target->capture != nullptr) {
    if (blocking) return refuseWhileCapturing(*target);
    checkCopy(rt, to, from, bytes, kind, call, site);
    target->capture->nodes.push_back([=, &rt](CudaEmulationStream& on) {
      copyOn(rt, on, to, from, bytes, kind, false, call, site);
    });
    return cudaSuccess;
  }
  copyOn(rt, *target, to, from, bytes, kind, blocking, call, site);
  return record(rt.waited());
}

void fillOn(Runtime& rt, CudaEmulationStream& target, void* to, int value, std::size_t bytes,
            bool blocking, const char* call, const std::source_location& site) {
  rt.checkOperand(to, bytes, true, call, "destination", site);
  count(&ApiCounters::memsets);
  if (blocking) count(&ApiCounters::host_waits);
  const std::uint64_t sequence = rt.enqueue(target, [=] {
    if (bytes != 0) std::memset(to, value, bytes);
  });
  if (blocking) rt.runUntil(target, sequence);
}

cudaError_t fill(void* to, int value, std::size_t bytes, cudaStream_t handle, bool blocking,
                 const char* call, const std::source_location& site) {
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  CudaEmulationStream* target = rt.stream(handle);
  if (target == nullptr) return record(cudaErrorInvalidResourceHandle);
  if (target->capture != nullptr) {
    if (blocking) return refuseWhileCapturing(*target);
    rt.checkOperand(to, bytes, true, call, "destination", site);
    target->capture->nodes.push_back(
        [=, &rt](CudaEmulationStream& on) { fillOn(rt, on, to, value, bytes, false, call, site); });
    return cudaSuccess;
  }
  fillOn(rt, *target, to, value, bytes, blocking, call, site);
  return record(rt.waited());
}

// An event's record on `target`: its timestamp when the stream reaches it.
void recordOn(Runtime& rt, CudaEmulationStream& target, cudaEvent_t event) {
  count(&ApiCounters::event_records);
  event->stream = &target;
  event->recorded = true;
  event->sequence = rt.enqueue(target, [event] { event->when = std::chrono::steady_clock::now(); });
}

// Destroys a handle the runtime made (an event, a graph, a graph instance).
template <class Handle>
cudaError_t destroyKnown(Handle handle) {
  countCall();
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  if (!rt.known(handle)) return record(cudaErrorInvalidResourceHandle);
  rt.remove(handle);
  delete handle;
  return cudaSuccess;
}

}  // namespace

void enqueueLaunch(KernelLaunch launch) {
  countCall();
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  CudaEmulationStream* target = rt.stream(launch.stream);
  if (target == nullptr) {
    record(cudaErrorInvalidResourceHandle);
    return;
  }
  const dim3& block = launch.block;
  if (!validDims(block, 1024, 1024, 64) ||
      static_cast<std::uint64_t>(block.x) * block.y * block.z > 1024 ||
      !validDims(launch.grid, 0x7FFFFFFFu, 65535, 65535) ||
      launch.shared_bytes > kMaxSharedBytesPerBlock) {
    record(cudaErrorInvalidConfiguration);
    return;
  }
  // The fiber stacks, mapped now: a grid that runs never runs short of them
  // (the pool keeps them, so a captured launch has its own at replay).
  if (!reserveStacks(launch)) {
    record(cudaErrorMemoryAllocation);
    return;
  }
  const auto launchOn = [&rt](CudaEmulationStream& on, const KernelLaunch& checked) {
    count(&ApiCounters::kernel_launches);
    rt.checkKernelArguments(checked);
    rt.enqueue(on, [checked] { runGrid(checked); });
  };
  if (target->capture != nullptr) {
    rt.checkKernelArguments(launch);
    target->capture->nodes.push_back(
        [launchOn, launch](CudaEmulationStream& on) { launchOn(on, launch); });
    return;
  }
  launchOn(*target, launch);
}

}  // namespace overlap::cuda_emulation::detail

using namespace overlap::cuda_emulation::detail;
using overlap::cuda_emulation::ApiCounters;

cudaError_t cudaGetDeviceCount(int* count) {
  countCall();
  if (count == nullptr) return record(cudaErrorInvalidValue);
  *count = 1;
  return cudaSuccess;
}

cudaError_t cudaGetDevice(int* device) {
  countCall();
  if (device == nullptr) return record(cudaErrorInvalidValue);
  *device = 0;
  return cudaSuccess;
}

cudaError_t cudaSetDevice(int device) {
  countCall();
  return device == 0 ? cudaSuccess : record(cudaErrorInvalidDevice);
}

cudaError_t cudaGetDeviceProperties(cudaDeviceProp* properties, int device) {
  countCall();
  if (properties == nullptr) return record(cudaErrorInvalidValue);
  if (device != 0) return record(cudaErrorInvalidDevice);
  *properties = cudaDeviceProp{};
  const int workers = workerThreadCount();
  std::snprintf(properties->name, sizeof properties->name, "CUDA emulation on the CPU, %d %s",
                workers, workers == 1 ? "thread" : "threads");
  properties->totalGlobalMem = static_cast<std::size_t>(sysconf(_SC_PHYS_PAGES)) *
                               static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  properties->sharedMemPerBlock = 48 * 1024;
  properties->warpSize = 32;
  properties->maxThreadsPerBlock = 1024;
  properties->maxThreadsDim[0] = properties->maxThreadsDim[1] = 1024;
  properties->maxThreadsDim[2] = 64;
  properties->maxGridSize[0] = 0x7FFFFFFF;
  properties->maxGridSize[1] = properties->maxGridSize[2] = 65535;
  properties->multiProcessorCount = workers;
  return cudaSuccess;
}

cudaError_t cudaDeviceSynchronize(CudaSite) {
  countCall();
  count(&ApiCounters::host_waits);
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  if (cudaError_t refused; refusedWhileThisThreadCaptures(refused)) return refused;
  rt.synchronizeAll();
  return record(rt.waited());
}

cudaError_t cudaGetLastError() {
  countCall();
  return std::exchange(t_last_error, cudaSuccess);
}

cudaError_t cudaPeekAtLastError() {
  countCall();
  return t_last_error;
}

cudaError_t cudaMalloc(void** pointer, std::size_t bytes, CudaSite site) {
  countCall();
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  if (cudaError_t refused; refusedWhileThisThreadCaptures(refused)) return refused;
  return record(rt.allocate(pointer, bytes, Space::kDevice, site));
}

cudaError_t cudaMallocHost(void** pointer, std::size_t bytes, CudaSite site) {
  countCall();
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  if (cudaError_t refused; refusedWhileThisThreadCaptures(refused)) return refused;
  return record(rt.allocate(pointer, bytes, Space::kPinned, site));
}

cudaError_t cudaFree(void* pointer, CudaSite site) {
  countCall();
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  if (cudaError_t refused; refusedWhileThisThreadCaptures(refused)) return refused;
  return record(rt.release(pointer, Space::kDevice, "cudaFree", site));
}

cudaError_t cudaFreeHost(void* pointer, CudaSite site) {
  countCall();
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  if (cudaError_t refused; refusedWhileThisThreadCaptures(refused)) return refused;
  return record(rt.release(pointer, Space::kPinned, "cudaFreeHost", site));
}

cudaError_t cudaMemcpy(void* to, const void* from, std::size_t bytes, cudaMemcpyKind kind,
                       CudaSite site) {
  countCall();
  return copy(to, from, bytes, kind, nullptr, true, "cudaMemcpy", site);
}

cudaError_t cudaMemcpyAsync(void* to, const void* from, std::size_t bytes, cudaMemcpyKind kind,
                            cudaStream_t stream, CudaSite site) {
  countCall();
  return copy(to, from, bytes, kind, stream, false, "cudaMemcpyAsync", site);
}

cudaError_t cudaMemset(void* to, int value, std::size_t bytes, CudaSite site) {
  countCall();
  return fill(to, value, bytes, nullptr, true, "cudaMemset", site);
}

cudaError_t cudaMemsetAsync(void* to, int value, std::size_t bytes, cudaStream_t stream,
                            CudaSite site) {
  countCall();
  return fill(to, value, bytes, stream, false, "cudaMemsetAsync", site);
}

cudaError_t cudaStreamCreate(cudaStream_t* stream) {
  return cudaStreamCreateWithFlags(stream, cudaStreamDefault);
}

cudaError_t cudaStreamCreateWithFlags(cudaStream_t* stream, unsigned flags) {
  countCall();
  if (stream == nullptr || (flags & ~cudaStreamNonBlocking) != 0) {
    return record(cudaErrorInvalidValue);
  }
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  if (rt.creationFails()) return record(cudaErrorMemoryAllocation);
  *stream = rt.createStream((flags & cudaStreamNonBlocking) == 0);
  return cudaSuccess;
}

cudaError_t cudaStreamDestroy(cudaStream_t stream) {
  countCall();
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  if (stream == nullptr || rt.stream(stream) == nullptr) {
    return record(cudaErrorInvalidResourceHandle);
  }
  rt.destroyStream(stream);
  return record(rt.waited());
}

cudaError_t cudaStreamSynchronize(cudaStream_t stream, CudaSite) {
  countCall();
  count(&ApiCounters::host_waits);
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  CudaEmulationStream* target = rt.stream(stream);
  if (target == nullptr) return record(cudaErrorInvalidResourceHandle);
  if (target->capture != nullptr) return refuseWhileCapturing(*target);
  rt.runUntil(*target, target->enqueued);
  return record(rt.waited());
}

// Waiting is what runs work here, so a query runs it too: a polling loop ends.
cudaError_t cudaStreamQuery(cudaStream_t stream, CudaSite site) {
  return cudaStreamSynchronize(stream, site);
}

cudaError_t cudaStreamWaitEvent(cudaStream_t stream, cudaEvent_t event, unsigned flags) {
  countCall();
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  CudaEmulationStream* target = rt.stream(stream);
  if (target == nullptr || !rt.known(event)) return record(cudaErrorInvalidResourceHandle);
  if (flags != 0) return record(cudaErrorInvalidValue);
  if (target->capture != nullptr) return refuseWhileCapturing(*target);
  if (event->recorded && event->stream != nullptr) {
    rt.enqueue(*target, [] {}, {{event->stream, event->sequence}});
  }
  return cudaSuccess;
}

cudaError_t cudaLaunchHostFunc(cudaStream_t stream, cudaHostFn_t fn, void* user_data) {
  countCall();
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  CudaEmulationStream* target = rt.stream(stream);
  if (target == nullptr) return record(cudaErrorInvalidResourceHandle);
  if (fn == nullptr) return record(cudaErrorInvalidValue);
  if (target->capture != nullptr) return refuseWhileCapturing(*target);
  rt.enqueue(*target, [fn, user_data] { fn(user_data); });
  return cudaSuccess;
}

cudaError_t cudaEventCreate(cudaEvent_t* event) {
  return cudaEventCreateWithFlags(event, cudaEventDefault);
}

cudaError_t cudaEventCreateWithFlags(cudaEvent_t* event, unsigned flags) {
  countCall();
  if (event == nullptr || (flags & ~(cudaEventBlockingSync | cudaEventDisableTiming)) != 0) {
    return record(cudaErrorInvalidValue);
  }
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  if (rt.creationFails()) return record(cudaErrorMemoryAllocation);
  *event = new CudaEmulationEvent;
  (*event)->timing = (flags & cudaEventDisableTiming) == 0;
  rt.add(*event);
  return cudaSuccess;
}

cudaError_t cudaEventDestroy(cudaEvent_t event) {
  return destroyKnown(event);
}

cudaError_t cudaEventRecord(cudaEvent_t event, cudaStream_t stream) {
  return cudaEventRecordWithFlags(event, stream, cudaEventRecordDefault);
}

cudaError_t cudaEventRecordWithFlags(cudaEvent_t event, cudaStream_t stream, unsigned flags) {
  countCall();
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  CudaEmulationStream* target = rt.stream(stream);
  if (target == nullptr || !rt.known(event)) return record(cudaErrorInvalidResourceHandle);
  if ((flags & ~cudaEventRecordExternal) != 0) return record(cudaErrorInvalidValue);
  if (target->capture != nullptr) {
    // A plain record in a capture only orders streams on a GPU; not emulated.
    if (flags != cudaEventRecordExternal) return refuseWhileCapturing(*target);
    target->capture->nodes.push_back([event, &rt](CudaEmulationStream& on) {
      if (!rt.known(event)) fail("a graph launched an event record node of a destroyed event");
      recordOn(rt, on, event);
    });
    return cudaSuccess;
  }
  recordOn(rt, *target, event);
  return cudaSuccess;
}

cudaError_t cudaEventSynchronize(cudaEvent_t event, CudaSite) {
  countCall();
  count(&ApiCounters::host_waits);
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  if (!rt.known(event)) return record(cudaErrorInvalidResourceHandle);
  if (event->recorded && event->stream != nullptr) rt.runUntil(*event->stream, event->sequence);
  return record(rt.waited());
}

cudaError_t cudaEventQuery(cudaEvent_t event, CudaSite site) {
  return cudaEventSynchronize(event, site);
}

cudaError_t cudaEventElapsedTime(float* ms, cudaEvent_t start, cudaEvent_t end) {
  countCall();
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  if (ms == nullptr) return record(cudaErrorInvalidValue);
  if (!rt.known(start) || !rt.known(end) || !start->timing || !end->timing || !start->recorded ||
      !end->recorded) {
    return record(cudaErrorInvalidResourceHandle);
  }
  for (const cudaEvent_t event : {start, end}) {
    if (event->stream != nullptr && event->stream->completed < event->sequence) {
      return record(cudaErrorNotReady);
    }
  }
  *ms = std::chrono::duration<float, std::milli>(end->when - start->when).count();
  return cudaSuccess;
}

cudaError_t cudaStreamBeginCapture(cudaStream_t stream, cudaStreamCaptureMode mode) {
  countCall();
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  CudaEmulationStream* target = rt.stream(stream);
  if (target == nullptr) return record(cudaErrorInvalidResourceHandle);
  if (mode < cudaStreamCaptureModeGlobal || mode > cudaStreamCaptureModeRelaxed) {
    return record(cudaErrorInvalidValue);
  }
  // The legacy default stream cannot capture; nor can a stream twice, or a
  // thread two streams.
  if (stream == nullptr || target->capture != nullptr || t_capturing != nullptr) {
    return record(cudaErrorStreamCaptureUnsupported);
  }
  target->capture = new CudaEmulationGraph;
  target->capture_spoiled = false;
  t_capturing = target;
  return cudaSuccess;
}

cudaError_t cudaStreamEndCapture(cudaStream_t stream, cudaGraph_t* graph) {
  countCall();
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  CudaEmulationStream* target = rt.stream(stream);
  if (target == nullptr || graph == nullptr) return record(cudaErrorInvalidValue);
  if (target->capture == nullptr) return record(cudaErrorInvalidValue);
  if (t_capturing != target) return record(cudaErrorStreamCaptureWrongThread);
  CudaEmulationGraph* captured = std::exchange(target->capture, nullptr);
  t_capturing = nullptr;
  if (target->capture_spoiled) {
    delete captured;
    *graph = nullptr;
    return record(cudaErrorStreamCaptureInvalidated);
  }
  rt.add(captured);
  *graph = captured;
  return cudaSuccess;
}

cudaError_t cudaGraphInstantiate(cudaGraphExec_t* exec, cudaGraph_t graph,
                                 unsigned long long flags) {
  countCall();
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  if (exec == nullptr || flags != 0) return record(cudaErrorInvalidValue);
  if (!rt.known(graph)) return record(cudaErrorInvalidResourceHandle);
  if (rt.creationFails()) return record(cudaErrorMemoryAllocation);
  *exec = new CudaEmulationGraphExec{graph->nodes};
  rt.add(*exec);
  return cudaSuccess;
}

cudaError_t cudaGraphLaunch(cudaGraphExec_t exec, cudaStream_t stream) {
  countCall();
  Runtime& rt = runtime();
  const std::lock_guard lock(rt.mutex);
  if (CudaEmulationStream* target = rt.stream(stream); target != nullptr && rt.known(exec)) {
    // A graph launched into a capture becomes a child graph on a GPU; not emulated.
    if (target->capture != nullptr) return refuseWhileCapturing(*target);
    for (const auto& node : exec->nodes) node(*target);
    return cudaSuccess;
  }
  return record(cudaErrorInvalidResourceHandle);
}

cudaError_t cudaGraphExecDestroy(cudaGraphExec_t exec) {
  return destroyKnown(exec);
}

cudaError_t cudaGraphDestroy(cudaGraph_t graph) {
  return destroyKnown(graph);
}

namespace overlap::cuda_emulation {

ApiCounters apiCounters() {
  const std::lock_guard lock(detail::g_counters_mutex);
  return detail::g_counters;
}

std::uint64_t liveDeviceBytes() {
  detail::Runtime& rt = detail::runtime();
  const std::lock_guard lock(rt.mutex);
  return rt.liveBytes(detail::Space::kDevice);
}

std::uint64_t livePinnedBytes() {
  detail::Runtime& rt = detail::runtime();
  const std::lock_guard lock(rt.mutex);
  return rt.liveBytes(detail::Space::kPinned);
}

LiveHandles liveHandles() {
  detail::Runtime& rt = detail::runtime();
  const std::lock_guard lock(rt.mutex);
  return rt.liveHandles();
}

void failHandleCreation(std::uint64_t nth) {
  detail::Runtime& rt = detail::runtime();
  const std::lock_guard lock(rt.mutex);
  rt.failCreation(nth);
}

}  // namespace overlap::cuda_emulation
