// gpusap: the GPU sort-and-sweep pair finder.  The boxes are sorted on the
// axis where their centres spread widest, each box's candidates (the boxes
// that start inside its extent on that axis) are counted by binary search,
// and an exclusive scan of the counts hands the candidates out to warps in
// equal shares, so a long box costs its candidates, not a serial scan.  The
// rules the kernels keep are in gpu/gpu_sap_kernels.cuh.
//
// The pair set stays on the device.  Each frame the found pairs (64-bit
// pairKey()s) are radix sorted; added = this frame's pairs not in last
// frame's, removed = last frame's not in this frame's, each found by binary
// search and compacted in order, so both come back sorted (no host sort).
// Sorts, scan and compaction are CUB's (the emulation build's stand-ins:
// gpu/emulation/cub/).
//
// One frame is two rounds.  launch() uploads the boxes and enqueues the
// axis, keys, sort, counts, scan and sweep, then a copy of the pair count;
// finish() waits for that count (CUB's calls take their item counts from the
// host), sweeps again into more room if the pairs overflowed, then enqueues
// the pair sort, the two selections and one copy of the counts with the
// lists' heads; lists longer than the head are fetched again.
//
// Invariants, each with its reason:
// - Device memory is at most 64 bytes per box slot plus 24 per pair of
//   capacity, and CUB's temporaries: boxes 32, sort keys and slots 2 x (4 +
//   4), candidate offsets 8 per box; three pair-key buffers (last frame's
//   set, this frame's, the sort's other half) of 8 per pair.  The lists of
//   changes reuse them: added goes to the buffer the sort left free, removed
//   is compacted in place over last frame's set, which is then done with.
// - The pair capacity is the most pairs any frame found, grown to at least
//   double when exceeded; box buffers grow the same way with the slot count.
// - Slots never shrink, so last frame's pairs name valid slots after growth.
// - launch() only enqueues; finish() is where the host waits.
#include <cuda_runtime.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <cub/cub.cuh>
#include <source_location>
#include <stdexcept>
#include <string>

#include "gpu/base/stopwatch.h"
#include "gpu/cuda_buffers.h"
#include "gpu/cuda_check.h"
#include "gpu/finish_frame.h"
#include "gpu/gpu_pair_finders.h"
#include "gpu/gpu_sap_kernels.cuh"
#include "gpu/pinned_staging.h"

namespace overlap::gpu {
namespace {

using namespace sap_kernels;

// The entries of each list that come back with the counts: a frame that
// changes fewer pairs (the common case) needs no further copy.  32 KiB a list.
constexpr std::size_t kHeadEntries = 1u << 12;
constexpr unsigned kMaxBlocks = 1u << 16;
// Sweep blocks per multiprocessor at least, whatever n: the candidates
// outnumber the boxes, and the grid strides over them.
constexpr unsigned kSweepBlocksPerSm = 8;

struct HostBlock {
  unsigned long long pairs;
  unsigned long long changes[2];  // added, removed
  IndexPair added[kHeadEntries];
  IndexPair removed[kHeadEntries];
};

unsigned blocksFor(std::uint64_t items) {
  const std::uint64_t blocks = (items + kThreadsPerBlock - 1) / kThreadsPerBlock;
  return static_cast<unsigned>(std::clamp<std::uint64_t>(blocks, 1, kMaxBlocks));
}

class GpuSapPairFinder final : public PairFinder {
 public:
  GpuSapPairFinder() {
    CUDA_CHECK(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking));
    for (cudaEvent_t& event : events_) CUDA_CHECK(cudaEventCreate(&event));
    int device = 0;
    cudaDeviceProp properties{};
    CUDA_CHECK(cudaGetDevice(&device));
    CUDA_CHECK(cudaGetDeviceProperties(&properties, device));
    sweep_blocks_ = std::max(1, properties.multiProcessorCount) * kSweepBlocksPerSm;
    counters_ = DeviceBuffer<FrameCounters>(1);
    host_ = PinnedBuffer<HostBlock>(1);
  }

  // Waits for work in flight before the buffers go; errors cannot be thrown here.
  ~GpuSapPairFinder() override {
    cudaStreamSynchronize(stream_);
    for (cudaEvent_t event : events_) cudaEventDestroy(event);
    cudaStreamDestroy(stream_);
  }

  GpuSapPairFinder(const GpuSapPairFinder&) = delete;
  GpuSapPairFinder& operator=(const GpuSapPairFinder&) = delete;

  std::string_view name() const override { return "gpusap"; }
  double lastSearchMs() const override { return last_search_ms_; }
  double lastLaunchToFinishMs() const override { return last_launch_to_finish_ms_; }
  DeviceWork lastDeviceWork() const override { return last_work_; }

  std::span<ObjectBounds> stagingFor(std::size_t count) override {
    return staging_.room(name(), in_flight_, count);
  }

  void launch(std::span<const ObjectBounds> objects) override {
    if (in_flight_) throw std::runtime_error("gpusap: launch() called twice without finish()");
    launch_watch_ = HostStopwatch();
    work_ = DeviceWork{};
    slot_count_ = checkedSlotCount(name(), slot_count_, objects.size());
    reserveBoxBuffers(objects.size());
    work_.host_bytes_copied += staging_.stage(objects);
    record(kStarted);
    if (!objects.empty()) {
      CUDA_CHECK_COUNTED(work_.api_calls,
                         cudaMemcpyAsync(objects_.data(), staging_.data(), objects.size_bytes(),
                                         cudaMemcpyHostToDevice, stream_));
      work_.bytes_to_device += objects.size_bytes();
    }
    record(kUploaded);
    // 0xFF: every centre bound at its start (see FrameCounters), every count huge;
    // the counts are zeroed next.
    CUDA_CHECK_COUNTED(work_.api_calls,
                       cudaMemsetAsync(counters_.data(), 0xFF, sizeof(FrameCounters), stream_));
    CUDA_CHECK_COUNTED(work_.api_calls, cudaMemsetAsync(&counters_.data()->pairs, 0,
                                                        3 * sizeof(unsigned long long), stream_));
    enqueueBoxSort();
    enqueueSweep();
    record(kSwept);
    download(&host_.data()->pairs, &counters_.data()->pairs, sizeof(unsigned long long));
    record(kCounted);
    in_flight_ = true;
  }

  // The frame ends here whether this returns or throws.  After a throw,
  // previous_ still names the last frame the caller received a delta for.
  PairDelta finish() override {
    return finishFrame(name(), in_flight_, stream_, launch_watch_, last_launch_to_finish_ms_,
                       [&] { return collectDelta(); });
  }

 private:
  enum Event { kStarted, kUploaded, kSwept, kCounted, kDiffing, kDiffed, kDownloaded, kEventCount };

  // Every runtime call of a frame is counted (DeviceWork::api_calls) and
  // checked: in place with CUDA_CHECK_COUNTED, or, when a helper below makes
  // it for its caller, with the caller's file and line.
  using Where = std::source_location;
  void call(cudaError_t status, const char* what, Where where) {
    ++work_.api_calls;
    checkCuda(status, what, where);
  }

  void record(Event event, Where where = Where::current()) {
    call(cudaEventRecord(events_[event], stream_), "cudaEventRecord", where);
  }

  void download(void* to, const void* from, std::size_t bytes, Where where = Where::current()) {
    if (bytes == 0) return;
    call(cudaMemcpyAsync(to, from, bytes, cudaMemcpyDeviceToHost, stream_), "cudaMemcpyAsync",
         where);
    work_.bytes_from_device += bytes;
  }

  // Runs a CUB call twice as CUB's protocol asks: the size query, then (with
  // temp_ grown to fit) the work.
  template <class CubCall>
  void cub(CubCall cub_call, Where where = Where::current()) {
    std::size_t bytes = 0;
    call(cub_call(nullptr, bytes), "a CUB size query", where);
    // At least one byte: a null temp_ would make the second call a query too.
    reserveDiscarding(temp_, std::max<std::size_t>(bytes, 1));  // cudaFree waits for its users
    bytes = temp_.size();
    call(cub_call(temp_.data(), bytes), "a CUB device-wide call", where);
  }

  // After each kernel launch: its own errors, and the launch counted.
  void launched(Where where = Where::current()) {
    call(cudaGetLastError(), "a gpusap kernel launch", where);
    ++work_.api_calls;
  }

  void reserveBoxBuffers(std::size_t n) {
    if (n <= objects_.size()) return;
    reserveDiscarding(objects_, n);
    for (auto* buffer : {&keys_[0], &keys_[1], &slots_[0], &slots_[1]}) {
      reserveDiscarding(*buffer, objects_.size());
    }
    reserveDiscarding(offsets_, objects_.size() + 1);
  }

  // Sorts the slots by their boxes' min on the sweep axis, into sorted_.
  void enqueueBoxSort() {
    const std::uint32_t n = slot_count_;
    if (n == 0) return;
    centreBoundsKernel<<<blocksFor(n), kThreadsPerBlock, 0, stream_>>>(objects_.data(), n,
                                                                       counters_.data());
    launched();
    sortKeysKernel<<<blocksFor(n), kThreadsPerBlock, 0, stream_>>>(
        objects_.data(), n, static_cast<const FrameCounters*>(counters_.data()), keys_[0].data(),
        slots_[0].data());
    launched();
    cub::DoubleBuffer<std::uint32_t> keys(keys_[0].data(), keys_[1].data());
    cub::DoubleBuffer<std::uint32_t> slots(slots_[0].data(), slots_[1].data());
    cub([&](void* temp, std::size_t& bytes) {
      return cub::DeviceRadixSort::SortPairs(temp, bytes, keys, slots, n, 0, 32, stream_);
    });
    sorted_keys_ = keys.Current();
    sorted_slots_ = slots.Current();
  }

  // Counts, scans and sweeps into the pair buffer this frame writes.
  void enqueueSweep() {
    const std::uint32_t n = slot_count_;
    if (n == 0) return;
    candidateCountKernel<<<blocksFor(std::uint64_t{n} + 1), kThreadsPerBlock, 0, stream_>>>(
        objects_.data(), n, static_cast<const FrameCounters*>(counters_.data()),
        static_cast<const std::uint32_t*>(sorted_keys_),
        static_cast<const std::uint32_t*>(sorted_slots_), offsets_.data());
    launched();
    cub([&](void* temp, std::size_t& bytes) {
      return cub::DeviceScan::ExclusiveSum(temp, bytes, offsets_.data(), offsets_.data(),
                                           std::uint64_t{n} + 1, stream_);
    });
    enqueueSweepKernel();
  }

  void enqueueSweepKernel() {
    const std::uint32_t n = slot_count_;
    if (n == 0) return;
    DeviceBuffer<std::uint64_t>& current = pairs_[(previous_ + 1) % 3];
    sweepKernel<<<std::max(blocksFor(n), std::min(sweep_blocks_, kMaxBlocks)), kThreadsPerBlock, 0,
                  stream_>>>(static_cast<const ObjectBounds*>(objects_.data()), n,
                             static_cast<const std::uint32_t*>(sorted_slots_),
                             static_cast<const unsigned long long*>(offsets_.data()),
                             counters_.data(), current.data(),
                             static_cast<unsigned long long>(pairCapacity()));
    launched();
  }

  // The room every pair buffer but last frame's has (they are grown together).
  std::size_t pairCapacity() const {
    return std::min(pairs_[(previous_ + 1) % 3].size(), pairs_[(previous_ + 2) % 3].size());
  }

  // The sweep found more pairs than fit: grow, and sweep again (the sorted
  // boxes and offsets are still on the device).
  void resweep(std::size_t pairs) {
    for (int role = 1; role <= 2; ++role) {
      DeviceBuffer<std::uint64_t>& buffer = pairs_[(previous_ + role) % 3];
      reserveDiscarding(buffer, pairs);
    }
    CUDA_CHECK_COUNTED(work_.api_calls, cudaMemsetAsync(&counters_.data()->pairs, 0,
                                                        sizeof(unsigned long long), stream_));
    enqueueSweepKernel();
    download(&host_.data()->pairs, &counters_.data()->pairs, sizeof(unsigned long long));
    record(kCounted);
    CUDA_CHECK_COUNTED(work_.api_calls, cudaEventSynchronize(events_[kCounted]));
  }

  PairDelta collectDelta() {
    CUDA_CHECK_COUNTED(work_.api_calls, cudaEventSynchronize(events_[kCounted]));
    const std::size_t pairs = host_.data()->pairs;
    if (pairs > pairCapacity()) resweep(pairs);
    record(kDiffing);
    const int current = enqueueDiff(pairs);
    record(kDiffed);
    // The counts and the heads of both lists, in one round trip.
    const std::size_t previous_pairs = previous_pairs_;
    download(host_.data()->changes, &counters_.data()->added, 2 * sizeof(unsigned long long));
    download(host_.data()->added, pairs_[freeBuffer(current)].data(),
             std::min(pairs, kHeadEntries) * sizeof(IndexPair));
    download(host_.data()->removed, pairs_[previous_].data(),
             std::min(previous_pairs, kHeadEntries) * sizeof(IndexPair));
    record(kDownloaded);
    CUDA_CHECK_COUNTED(work_.api_calls, cudaEventSynchronize(events_[kDownloaded]));
    const std::size_t added_count = host_.data()->changes[0];
    const std::size_t removed_count = host_.data()->changes[1];
    IndexPair* added =
        joinHeadAndTail(host_.data()->added, pairs_[freeBuffer(current)], host_added_, added_count);
    IndexPair* removed =
        joinHeadAndTail(host_.data()->removed, pairs_[previous_], host_removed_, removed_count);
    if (std::max(added_count, removed_count) > kHeadEntries) {
      record(kDownloaded);
      CUDA_CHECK_COUNTED(work_.api_calls, cudaEventSynchronize(events_[kDownloaded]));
    }
    noteTimes();
    previous_ = current;  // nothing below can fail: this frame is now the reference
    previous_pairs_ = pairs;
    last_work_ = work_;
    return PairDelta{{added, added_count}, {removed, removed_count}};
  }

  // The one of the three pair buffers that is neither last frame's nor `current`.
  int freeBuffer(int current) const { return 3 - previous_ - current; }

  // Sorts this frame's pairs and enqueues the two selections; returns the
  // index of the buffer that holds this frame's sorted set.
  int enqueueDiff(std::size_t pairs) {
    const int first = (previous_ + 1) % 3;
    const int second = (previous_ + 2) % 3;
    cub::DoubleBuffer<std::uint64_t> keys(pairs_[first].data(), pairs_[second].data());
    // pairKey()s of slots below n: the low half needs bit_width(n) bits.
    const int end_bit = 32 + std::bit_width(slot_count_);
    cub([&](void* temp, std::size_t& bytes) {
      return cub::DeviceRadixSort::SortKeys(temp, bytes, keys, pairs, 0, end_bit, stream_);
    });
    const int current = keys.selector == 0 ? first : second;
    std::uint64_t* const this_frame = pairs_[current].data();
    std::uint64_t* const last_frame = pairs_[previous_].data();
    std::uint64_t* const free = pairs_[freeBuffer(current)].data();
    const auto previous_pairs = static_cast<std::int64_t>(previous_pairs_);
    unsigned long long* const added_count = &counters_.data()->added;
    unsigned long long* const removed_count = &counters_.data()->removed;
    cub([&](void* temp, std::size_t& bytes) {
      return cub::DeviceSelect::If(temp, bytes, this_frame, free, added_count,
                                   static_cast<std::int64_t>(pairs),
                                   NotIn{last_frame, previous_pairs_}, stream_);
    });
    cub([&](void* temp, std::size_t& bytes) {
      return cub::DeviceSelect::If(temp, bytes, last_frame, removed_count, previous_pairs,
                                   NotIn{this_frame, pairs}, stream_);
    });
    toIndexPairsKernel<<<blocksFor(std::max<std::size_t>(pairs, previous_pairs_)), kThreadsPerBlock,
                         0, stream_>>>(free, last_frame,
                                       static_cast<const FrameCounters*>(counters_.data()));
    launched();
    return current;
  }

  // The list of `count` entries whose head is `head`: the head itself when
  // it holds them all, else `host`, filled with the head and (queued; the
  // caller waits) the device tail.
  IndexPair* joinHeadAndTail(IndexPair* head, const DeviceBuffer<std::uint64_t>& list,
                             PinnedBuffer<IndexPair>& host, std::size_t count) {
    if (count <= kHeadEntries) return head;
    reserveDiscarding(host, count);
    std::memcpy(host.data(), head, kHeadEntries * sizeof(IndexPair));
    work_.host_bytes_copied += kHeadEntries * sizeof(IndexPair);
    download(host.data() + kHeadEntries, list.data() + kHeadEntries,
             (count - kHeadEntries) * sizeof(IndexPair));
    return host.data();
  }

  float elapsed(Event from, Event to, Where where = Where::current()) {
    float ms = 0;
    call(cudaEventElapsedTime(&ms, events_[from], events_[to]), "cudaEventElapsedTime", where);
    return ms;
  }

  void noteTimes() {
    work_.upload_ms = elapsed(kStarted, kUploaded);
    work_.kernels_ms = elapsed(kUploaded, kSwept) + elapsed(kDiffing, kDiffed);
    work_.download_ms = elapsed(kSwept, kCounted) + elapsed(kDiffed, kDownloaded);
    last_search_ms_ = elapsed(kStarted, kDownloaded);
  }

  cudaStream_t stream_ = nullptr;
  cudaEvent_t events_[kEventCount] = {};
  unsigned sweep_blocks_ = 1;

  std::uint32_t slot_count_ = 0;
  bool in_flight_ = false;
  HostStopwatch launch_watch_;
  double last_search_ms_ = 0;
  double last_launch_to_finish_ms_ = 0;
  DeviceWork work_;  // the frame in progress
  DeviceWork last_work_;

  PinnedStaging staging_;                 // this frame's boxes, from the caller
  DeviceBuffer<ObjectBounds> objects_;    // ... uploaded, by slot
  DeviceBuffer<std::uint32_t> keys_[2];   // sort keys, and CUB's other half
  DeviceBuffer<std::uint32_t> slots_[2];  // slots in key order, and CUB's other half
  std::uint32_t* sorted_keys_ = nullptr;  // where the sort left them
  std::uint32_t* sorted_slots_ = nullptr;
  DeviceBuffer<unsigned long long> offsets_;  // per rank: candidates, then their scan
  DeviceBuffer<FrameCounters> counters_;
  DeviceBuffer<unsigned char> temp_;  // CUB's temporary storage, shared by its calls
  // pairs_[previous_] holds last frame's sorted pair keys (previous_pairs_ of
  // them); the other two are this frame's and the sort's other half.
  DeviceBuffer<std::uint64_t> pairs_[3];
  int previous_ = 0;
  std::size_t previous_pairs_ = 0;
  PinnedBuffer<HostBlock> host_;
  PinnedBuffer<IndexPair> host_added_;  // whole lists, when longer than the head
  PinnedBuffer<IndexPair> host_removed_;
};

}  // namespace

std::unique_ptr<PairFinder> makeGpuSapPairFinder() {
  return std::make_unique<GpuSapPairFinder>();
}

}  // namespace overlap::gpu
