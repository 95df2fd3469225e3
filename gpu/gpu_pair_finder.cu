// gpubf: the GPU brute-force pair finder, built so that almost nothing but
// the answer crosses the bus.
//
// One warp computes one 32-bit word: each lane decodes its pair p exactly
// (pair_logic::pairAt), tests it, and __ballot_sync gathers the 32 results.
// The warp XORs the word with last frame's and appends the changed pairs to
// an "added" or a "removed" list through one atomic per list per word, so only
// those lists and their two counts are copied back.  The counts keep growing
// past the lists' capacity: an overflow is seen on the host and the changes
// are collected again, from the two frames' words, into longer lists.
//
// Memory: two word buffers (last frame's, read; this frame's, written) swap
// roles every frame; words past the last pair are zero, so growing the slot
// count appends pairs that had no overlap.  All buffers live across frames and
// grow geometrically; host buffers are pinned so the copies are asynchronous.
// launch() only enqueues work on the finder's stream; finish() waits on events.
#include <cuda_runtime.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

#include "gpu/cuda_buffers.h"
#include "gpu/gpu_pair_finders.h"
#include "gpu/pair_logic.h"

namespace overlap::gpu {
namespace {

using pair_logic::kBitsPerWord;

constexpr unsigned kThreadsPerBlock = 256;
constexpr unsigned kWarpsPerBlock = kThreadsPerBlock / kBitsPerWord;
// Enough blocks to fill any current GPU; larger problems loop (grid-stride).
constexpr std::uint64_t kMaxBlocks = 1u << 16;
constexpr std::size_t kInitialListCapacity = 1u << 14;
// launch() copies this many entries of each list back with the counts, before
// it knows how many there are: a frame that changes fewer pairs (the common
// case) then needs one round trip, not two.  32 KiB a list, a few microseconds.
constexpr std::size_t kSpeculativeCopy = 1u << 12;
constexpr unsigned kFullWarp = 0xFFFFFFFFu;

struct ChangeLists {
  IndexPair* added;
  IndexPair* removed;
  unsigned long long* counts;  // [0] added, [1] removed; may exceed capacity
  unsigned long long capacity;
};

// Called by all 32 lanes of a warp with the same word; appends the word's
// changed pairs.  Lane k handles bit k, so each list entry is written once.
__device__ void appendChanges(std::uint64_t word, std::uint32_t previous, std::uint32_t current,
                              const ChangeLists& lists) {
  if (previous == current) return;  // uniform across the warp
  const unsigned lane = threadIdx.x % kBitsPerWord;
  const std::uint32_t added = pair_logic::addedBits(previous, current);
  const std::uint32_t removed = pair_logic::removedBits(previous, current);
  unsigned long long added_base = 0;
  unsigned long long removed_base = 0;
  if (lane == 0) {
    if (added != 0)
      added_base = atomicAdd(&lists.counts[0], static_cast<unsigned long long>(__popc(added)));
    if (removed != 0)
      removed_base = atomicAdd(&lists.counts[1], static_cast<unsigned long long>(__popc(removed)));
  }
  added_base = __shfl_sync(kFullWarp, added_base, 0);
  removed_base = __shfl_sync(kFullWarp, removed_base, 0);
  const std::uint32_t lane_bit = 1u << lane;
  const std::uint32_t lanes_below = lane_bit - 1u;
  if ((added | removed) & lane_bit) {
    const bool is_added = (added & lane_bit) != 0;
    const unsigned long long slot = is_added ? added_base + __popc(added & lanes_below)
                                             : removed_base + __popc(removed & lanes_below);
    if (slot < lists.capacity) {
      (is_added ? lists.added : lists.removed)[slot] =
          pair_logic::pairAt(word * kBitsPerWord + lane);
    }
  }
}

__device__ std::uint64_t firstWarp() {
  return static_cast<std::uint64_t>(blockIdx.x) * kWarpsPerBlock + threadIdx.x / kBitsPerWord;
}

__device__ std::uint64_t warpCount() {
  return static_cast<std::uint64_t>(gridDim.x) * kWarpsPerBlock;
}

__global__ void __launch_bounds__(kThreadsPerBlock)
    findPairsKernel(const ObjectBounds* __restrict__ objects, std::uint64_t pair_count,
                    std::uint64_t word_count, const std::uint32_t* __restrict__ previous_words,
                    std::uint32_t* __restrict__ current_words, ChangeLists lists) {
  const unsigned lane = threadIdx.x % kBitsPerWord;
  for (std::uint64_t word = firstWarp(); word < word_count; word += warpCount()) {
    const std::uint64_t p = word * kBitsPerWord + lane;
    bool pairs = false;
    if (p < pair_count) {
      const IndexPair ab = pair_logic::pairAt(p);
      pairs = pair_logic::objectsPair(objects[ab.a], objects[ab.b]);
    }
    const std::uint32_t current = __ballot_sync(kFullWarp, pairs);
    const std::uint32_t previous = previous_words[word];
    if (lane == 0) current_words[word] = current;
    appendChanges(word, previous, current, lists);
  }
}

// The change collection alone, rerun into longer lists after an overflow.
__global__ void __launch_bounds__(kThreadsPerBlock)
    collectChangesKernel(std::uint64_t word_count, const std::uint32_t* __restrict__ previous_words,
                         const std::uint32_t* __restrict__ current_words, ChangeLists lists) {
  for (std::uint64_t word = firstWarp(); word < word_count; word += warpCount()) {
    appendChanges(word, previous_words[word], current_words[word], lists);
  }
}

unsigned blocksFor(std::uint64_t word_count) {
  return static_cast<unsigned>(
      std::min((word_count + kWarpsPerBlock - 1) / kWarpsPerBlock, kMaxBlocks));
}

class GpuPairFinder final : public PairFinder {
 public:
  GpuPairFinder() {
    CUDA_CHECK(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking));
    CUDA_CHECK(cudaEventCreate(&search_started_));
    CUDA_CHECK(cudaEventCreate(&counts_ready_));
    CUDA_CHECK(cudaEventCreate(&lists_ready_));
    counts_ = DeviceBuffer<unsigned long long>(2);
    host_counts_ = PinnedBuffer<unsigned long long>(2);
    reserveDiscarding(added_, kInitialListCapacity);
    reserveDiscarding(removed_, kInitialListCapacity);
    reserveDiscarding(host_added_, kSpeculativeCopy);
    reserveDiscarding(host_removed_, kSpeculativeCopy);
  }

  // Waits for work in flight before the buffers go; errors cannot be thrown here.
  ~GpuPairFinder() override {
    cudaStreamSynchronize(stream_);
    cudaEventDestroy(lists_ready_);
    cudaEventDestroy(counts_ready_);
    cudaEventDestroy(search_started_);
    cudaStreamDestroy(stream_);
  }

  GpuPairFinder(const GpuPairFinder&) = delete;
  GpuPairFinder& operator=(const GpuPairFinder&) = delete;

  std::string_view name() const override { return "gpubf"; }
  double lastSearchMs() const override { return last_search_ms_; }

  void launch(std::span<const ObjectBounds> objects) override {
    if (in_flight_) throw std::runtime_error("gpubf: launch() called twice without finish()");
    slot_count_ = checkedSlotCount(name(), slot_count_, objects.size());
    pair_count_ = pair_logic::pairsBelow(slot_count_);
    growWords(pair_logic::wordCount(pair_count_));

    reserveDiscarding(staging_, objects.size());
    reserveDiscarding(objects_, objects.size());
    if (!objects.empty()) {
      // The caller's memory is pageable and may change once we return: stage it.
      std::memcpy(staging_.data(), objects.data(), objects.size_bytes());
    }
    // After the staging copy: the stream is idle until here, and an event
    // recorded earlier would count the host's memcpy as GPU time.
    CUDA_CHECK(cudaEventRecord(search_started_, stream_));
    if (!objects.empty()) {
      CUDA_CHECK(cudaMemcpyAsync(objects_.data(), staging_.data(), objects.size_bytes(),
                                 cudaMemcpyHostToDevice, stream_));
    }
    CUDA_CHECK(cudaMemsetAsync(counts_.data(), 0, 2 * sizeof(unsigned long long), stream_));
    if (word_count_ > 0) {
      findPairsKernel<<<blocksFor(word_count_), kThreadsPerBlock, 0, stream_>>>(
          objects_.data(), pair_count_, word_count_, words_[previous_].data(),
          words_[1 - previous_].data(), changeLists());
      CUDA_CHECK(cudaGetLastError());
    }
    enqueueCountsCopy();
    in_flight_ = true;
  }

  // The frame ends here whether this returns or throws.  After a throw no work
  // of it stays queued, and previous_ still names the last frame the caller
  // received a delta for, so the next frame's delta is taken against it.
  PairDelta finish() override {
    if (!in_flight_) throw std::runtime_error("gpubf: finish() called without launch()");
    in_flight_ = false;
    try {
      return collectDelta();
    } catch (...) {
      cudaStreamSynchronize(stream_);  // its own error is the one being thrown
      throw;
    }
  }

 private:
  PairDelta collectDelta() {
    CUDA_CHECK(cudaEventSynchronize(counts_ready_));
    const std::size_t added_count = host_counts_.data()[0];
    const std::size_t removed_count = host_counts_.data()[1];
    cudaEvent_t done = counts_ready_;
    if (std::max(added_count, removed_count) > kSpeculativeCopy) {
      // More changes than launch() copied back: fetch the whole lists.
      if (std::max(added_count, removed_count) > added_.size()) {
        recollectChanges(std::max(added_count, removed_count));
      }
      reserveDiscarding(host_added_, added_count);
      reserveDiscarding(host_removed_, removed_count);
      copyBack(added_, host_added_, added_count);
      copyBack(removed_, host_removed_, removed_count);
      CUDA_CHECK(cudaEventRecord(lists_ready_, stream_));
      CUDA_CHECK(cudaEventSynchronize(lists_ready_));
      done = lists_ready_;
    }
    float elapsed_ms = 0;
    CUDA_CHECK(cudaEventElapsedTime(&elapsed_ms, search_started_, done));
    last_search_ms_ = elapsed_ms;
    previous_ = 1 - previous_;  // nothing below can fail: this frame is now the reference

    // Atomics append in no fixed order; sorting restores the contract.
    IndexPair* const added = host_added_.data();
    IndexPair* const removed = host_removed_.data();
    std::sort(added, added + added_count);
    std::sort(removed, removed + removed_count);
    return PairDelta{{added, added_count}, {removed, removed_count}};
  }

  ChangeLists changeLists() const {
    return ChangeLists{added_.data(), removed_.data(), counts_.data(),
                       std::min(added_.size(), removed_.size())};
  }

  // The counts, and the lists' first kSpeculativeCopy entries on the chance
  // that they hold all of it.
  void enqueueCountsCopy() {
    CUDA_CHECK(cudaMemcpyAsync(host_counts_.data(), counts_.data(), 2 * sizeof(unsigned long long),
                               cudaMemcpyDeviceToHost, stream_));
    copyBack(added_, host_added_, kSpeculativeCopy);
    copyBack(removed_, host_removed_, kSpeculativeCopy);
    CUDA_CHECK(cudaEventRecord(counts_ready_, stream_));
  }

  void copyBack(const DeviceBuffer<IndexPair>& from, PinnedBuffer<IndexPair>& to,
                std::size_t count) {
    if (count == 0) return;
    CUDA_CHECK(cudaMemcpyAsync(to.data(), from.data(), count * sizeof(IndexPair),
                               cudaMemcpyDeviceToHost, stream_));
  }

  // Both word buffers cover `words`: the one previous_ names keeps last
  // frame's words, every other word is zero.  New buffers are filled before
  // they replace the old ones, so a throw leaves the old ones in place.
  void growWords(std::uint64_t words) {
    if (words > words_[0].size()) {
      const std::size_t capacity = std::max<std::size_t>(words, 2 * words_[0].size());
      DeviceBuffer<std::uint32_t> last_frame(capacity);
      DeviceBuffer<std::uint32_t> this_frame(capacity);
      CUDA_CHECK(cudaMemsetAsync(last_frame.data(), 0, capacity * sizeof(std::uint32_t), stream_));
      CUDA_CHECK(cudaMemsetAsync(this_frame.data(), 0, capacity * sizeof(std::uint32_t), stream_));
      if (word_count_ > 0) {
        CUDA_CHECK(cudaMemcpyAsync(last_frame.data(), words_[previous_].data(),
                                   word_count_ * sizeof(std::uint32_t), cudaMemcpyDeviceToDevice,
                                   stream_));
      }
      // The copy reads the old buffer, freed below.  Growth is rare: waiting costs nothing.
      CUDA_CHECK(cudaStreamSynchronize(stream_));
      words_[previous_] = std::move(last_frame);
      words_[1 - previous_] = std::move(this_frame);
    }
    word_count_ = words;
  }

  // The kernel counted `needed` changes on one list but stored only what fit:
  // collect them again from the two frames' words into lists that fit them.
  void recollectChanges(std::size_t needed) {
    // Both lists are replaced only once both exist: they share one capacity.
    const std::size_t capacity = std::max(needed, 2 * added_.size());
    DeviceBuffer<IndexPair> added(capacity);
    DeviceBuffer<IndexPair> removed(capacity);
    added_ = std::move(added);
    removed_ = std::move(removed);
    CUDA_CHECK(cudaMemsetAsync(counts_.data(), 0, 2 * sizeof(unsigned long long), stream_));
    collectChangesKernel<<<blocksFor(word_count_), kThreadsPerBlock, 0, stream_>>>(
        word_count_, words_[previous_].data(), words_[1 - previous_].data(), changeLists());
    CUDA_CHECK(cudaGetLastError());
    enqueueCountsCopy();
    CUDA_CHECK(cudaEventSynchronize(counts_ready_));
  }

  cudaStream_t stream_ = nullptr;
  cudaEvent_t search_started_ = nullptr;
  cudaEvent_t counts_ready_ = nullptr;
  cudaEvent_t lists_ready_ = nullptr;

  std::uint32_t slot_count_ = 0;
  std::uint64_t pair_count_ = 0;
  std::uint64_t word_count_ = 0;
  bool in_flight_ = false;
  double last_search_ms_ = 0;

  PinnedBuffer<ObjectBounds> staging_;  // this frame's boxes, copied from the caller
  DeviceBuffer<ObjectBounds> objects_;  // ... and uploaded from staging_
  // One bit per pair: words_[previous_] holds the last finished frame's, the
  // other the frame being searched (or last searched, if finish() threw).
  DeviceBuffer<std::uint32_t> words_[2];
  int previous_ = 0;
  DeviceBuffer<IndexPair> added_;            // this frame's appeared pairs, in atomic order
  DeviceBuffer<IndexPair> removed_;          // ... and vanished ones; same capacity as added_
  DeviceBuffer<unsigned long long> counts_;  // their counts, which may exceed the capacity
  PinnedBuffer<unsigned long long> host_counts_;
  PinnedBuffer<IndexPair> host_added_;  // the lists on the host, sorted by finish()
  PinnedBuffer<IndexPair> host_removed_;
};

}  // namespace

std::unique_ptr<PairFinder> makeGpuPairFinder() {
  return std::make_unique<GpuPairFinder>();
}

}  // namespace overlap::gpu
