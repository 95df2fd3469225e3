// What a program asked of the CUDA emulation's device, counted since the
// process started, what it holds now, and one injected failure: for cost reports
// (tests/gpu/gpu_frame_cost.cpp, run by scripts/gpu_kernel_cost.sh) and for tests of how much one
// frame asks.  The counts are the program's requests, the same on a GPU; no time is counted.
#pragma once

#include <cstdint>

namespace overlap::cuda_emulation {

struct ApiCounters {
  std::uint64_t api_calls = 0;  // runtime functions and launches (not error-string lookups)
  std::uint64_t kernel_launches = 0;
  std::uint64_t copies_to_device = 0;  // host to device
  std::uint64_t copies_to_host = 0;    // device to host
  std::uint64_t copies_on_device = 0;  // device to device (host to host is not counted)
  std::uint64_t memsets = 0;
  std::uint64_t bytes_to_device = 0;  // crossing the bus, by the copies above
  std::uint64_t bytes_to_host = 0;
  std::uint64_t event_records = 0;
  std::uint64_t host_waits = 0;  // synchronize and query calls, blocking copies and memsets

  // The counts between two snapshots.
  friend ApiCounters operator-(const ApiCounters& later, const ApiCounters& earlier) {
    return ApiCounters{later.api_calls - earlier.api_calls,
                       later.kernel_launches - earlier.kernel_launches,
                       later.copies_to_device - earlier.copies_to_device,
                       later.copies_to_host - earlier.copies_to_host,
                       later.copies_on_device - earlier.copies_on_device,
                       later.memsets - earlier.memsets,
                       later.bytes_to_device - earlier.bytes_to_device,
                       later.bytes_to_host - earlier.bytes_to_host,
                       later.event_records - earlier.event_records,
                       later.host_waits - earlier.host_waits};
  }
};

// A snapshot of the counts (gpu/emulation/runtime.cpp).
ApiCounters apiCounters();

// The bytes of device memory allocated and not yet freed, now: what a finder
// holds on the device (tests of its memory budget).
std::uint64_t liveDeviceBytes();
// The same for pinned host memory (cudaMallocHost).
std::uint64_t livePinnedBytes();

// The streams, events, graphs and graph executables created and not yet
// destroyed, now: what a program would leak (tests of the owning handles).
struct LiveHandles {
  std::uint64_t streams = 0;
  std::uint64_t events = 0;
  std::uint64_t graphs = 0;
  std::uint64_t graph_execs = 0;
  friend bool operator==(const LiveHandles&, const LiveHandles&) = default;
};
LiveHandles liveHandles();

// Makes the `nth` handle creation from now (a stream, an event or a graph
// executable; 1 the next one) fail with cudaErrorMemoryAllocation, once, as
// a device out of resources would; 0 makes none fail.  For tests that a
// throw between two creations leaks nothing.
void failHandleCreation(std::uint64_t nth);

}  // namespace overlap::cuda_emulation
