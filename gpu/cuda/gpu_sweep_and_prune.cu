// gpusap: the GPU sort-and-sweep pair finder, cpusap's method
// (gpu/cpu/cpu_sweep_and_prune.h) in the shape a GPU wants.  The boxes are
// sorted on the axis where their centres spread widest, within slabs of a
// second axis: each box has one entry per slab it reaches, and its
// candidates are the entries after it in its slab that start inside its
// extent on the sweep axis, counted by binary search.  An exclusive scan of
// the counts hands the candidates out to warps in equal shares, so a long
// box costs its candidates, not a serial scan.  The rules the kernels keep
// are in gpu/cuda/gpu_sweep_and_prune_kernels.cuh.
//
// Why slabs (docs/results/gpusap_candidates.md): along one axis a box meets
// every box in a slice across the whole scene, so candidates per box grow as
// n^(2/3) (4716 a box at 10^6 on scene 4: 4.7 10^9 tests, most of the 50 ms
// of kernels an H100 measured).  Slabs three box extents wide cut them to
// those of a column, n^(1/3) (136 a box at 10^6, 35 times fewer), for a
// 64-bit sort key and 1.33 entries a box.  A linear BVH (Karras, HPG 2012) also comes near the
// pairs, but walks a tree per box (divergent, O(log n) dependent loads)
// after a build of several kernels; an incremental sweep (PhysX) keeps
// per-pair state across frames that a full GPU re-sort does not need.  Slabs
// keep the sweep's flat, balanced candidate loop and cpusap's proven rules.
//
// The pair set stays on the device, as IndexPairs from the sweep to the
// host (no other form, no conversion).  Each frame the found pairs are radix
// sorted ((a, b) as one key, on the bits slots below n use); added = this
// frame's pairs not in last frame's, removed = last frame's not in this
// frame's, each found by binary search and compacted in order, so both come
// back sorted (no host sort).  Sorts, scans and compactions are CUB's (the
// emulation build's stand-ins: gpu/emulation/cub/).
//
// The steady frame's chain (docs/results/gpu_kernel_cost.md counts and
// times it): the upload; boundsKernel (bounds, and the empty slots filled);
// entryKernel (entries placed by atomics, no scan); CUB's sort of the
// entries; CUB's scan of the candidate counts, which it computes as it
// reads them; sweepKernel; CUB's sort of the pairs; CUB's two selections;
// packKernel (the result block, and the counters zeroed for the next
// frame); the copy back.  No memset a frame.
//
// One frame is one round trip: launch() uploads the boxes and enqueues the
// whole search, the selections and one copy back of the result block (the
// counts and up to kHeadEntries changes); finish() waits for it.  CUB takes
// its item counts from the host, so every call runs over capacities the
// host already knows: the entry and pair capacities, kept from earlier
// frames, with unused slots filled with keys above every real one.  A frame
// whose counts outgrow them is spoiled (it selects nothing, see the
// kernels' header); finish() grows the room and runs the search again, once.
// A frame that changed more pairs than the block holds fetches the lists'
// tails in a second copy.  The emulation runs the same calls.  A steady
// frame's calls take the same arguments every frame but for the rotation
// of the three pair buffers (three shapes), so a CUDA graph per shape could
// replay the chain; none is built yet.
//
// Invariants, each with its reason:
// - Device memory is 32 bytes per box slot (the box),
//   32 per entry of capacity (keys 2 x 8, slots 2 x 4, candidate offsets 8),
//   24 per pair of capacity (last frame's set, this frame's, the sort's other
//   half), the counters and result block, and CUB's temporaries.  The lists
//   of changes reuse the pair buffers: added goes to the buffer the sort
//   left free, removed is compacted in place over last frame's set, which is
//   then done with.
// - Capacities start at 2 entries and 2 pairs a box and grow to 5/4 of what
//   a frame wanted, at least doubling, so a growing scene retries rarely.
//   Entries stay near n whatever the sizes: slabs are three mean extents
//   wide, so the finite boxes' spans add up to about 2n + n/3 at most (a few
//   huge boxes widen the mean, and with it the slabs); only boxes with an
//   infinite coordinate reach every slab.
// - Slots never shrink, so last frame's pairs name valid slots after growth;
//   last frame's pair buffer is never reallocated while it holds the set.
// - launch() only enqueues; finish() is where the host waits.
// - A spoiled frame leaves last frame's set whole: its selections select
//   nothing, and CUB's compaction writes only what it selects.
#include <cuda_runtime.h>

#include <algorithm>
#include <bit>
#include <cub/cub.cuh>
#include <source_location>
#include <stdexcept>
#include <string>

#include "gpu/cuda/cuda_buffers.h"
#include "gpu/cuda/finder_device.h"
#include "gpu/cuda/finish_frame.h"
#include "gpu/cuda/gpu_sweep_and_prune_kernels.cuh"
#include "gpu/pair_finder.h"

namespace overlap::finders {
namespace {

using namespace sap_kernels;

// Sweep blocks per multiprocessor at least, whatever n: the candidates
// outnumber the boxes, and the grid strides over them.
constexpr unsigned kSweepBlocksPerSm = 8;
// Capacities: a first guess per box, and the headroom over what a frame wanted.
constexpr std::size_t kFirstEntriesPerBox = 2;
constexpr std::size_t kFirstPairsPerBox = 2;
std::size_t withHeadroom(std::size_t wanted) {
  return wanted + wanted / 4 + 64;
}

class GpuSweepAndPruneFinder final : public PairFinder {
 public:
  GpuSweepAndPruneFinder() {
    int device = 0;
    cudaDeviceProp properties{};
    CUDA_CHECK(cudaGetDevice(&device));
    CUDA_CHECK(cudaGetDeviceProperties(&properties, device));
    sweep_blocks_ = static_cast<unsigned>(std::min<std::uint64_t>(
        std::max(1, properties.multiProcessorCount) * kSweepBlocksPerSm, kMaxBlocks));
    counters_ = DeviceBuffer<FrameCounters>(1);
    // Zero for the first frame; each frame's last kernel zeroes them for the next.
    CUDA_CHECK(cudaMemsetAsync(counters_.data(), 0, sizeof(FrameCounters), device_.stream()));
    block_ = DeviceBuffer<SapResultBlock>(1);
    host_ = PinnedBuffer<SapResultBlock>(1);
  }

  GpuSweepAndPruneFinder(const GpuSweepAndPruneFinder&) = delete;
  GpuSweepAndPruneFinder& operator=(const GpuSweepAndPruneFinder&) = delete;

  std::string_view name() const override { return "gpusap"; }

 private:
  // The stage times are read from the last frame's events only here, when asked.
  SearchStats searchStats() const override {
    SearchStats stats;
    stats.device = device_.lastWorkTimed();
    stats.search_ms = stats.device.upload_ms + stats.device.kernels_ms + stats.device.download_ms;
    return stats;
  }

  std::span<ObjectBounds> staging(std::size_t count) override { return device_.stagingRoom(count); }

  void startSearch(std::span<const ObjectBounds> objects,
                   const std::span<const std::uint32_t>* /*changed*/) override {
    device_.begin();
    slot_count_ = checkedSlotCount(name(), slot_count_, objects.size());
    reserveBoxBuffers(objects.size());
    device_.stage(objects);
    device_.record(FinderDevice::kStarted);
    device_.upload(objects_.data(), objects.size());
    device_.record(FinderDevice::kUploaded);
    enqueueSearch();
  }

  // The frame ends here whether this returns or throws.  After a throw,
  // previous_ still names the last frame the caller received a delta for.
  PairDelta finishSearch() override {
    return finishFrame(device_.stream(), [&] { return collectDelta(); });
  }

  // Every runtime call of a frame is counted (DeviceWork::api_calls) and
  // checked with its caller's file and line, by device_ (gpu/cuda/finder_device.h).
  using Where = std::source_location;

  // Runs a CUB call.  CUB's protocol asks its temporary size first; that
  // query is made only while sizing_ (the first frame of a new shape of the
  // calls' arguments, enqueueSearch()), and temp_ grown to the largest
  // answer; other frames make only the call.
  template <class CubCall>
  void cub(CubCall cub_call, Where where = Where::current()) {
    if (sizing_) {
      std::size_t bytes = 0;
      device_.check(cub_call(nullptr, bytes), "a CUB size query", where);
      // At least one byte: a null temp_ would make the call a query too.
      reserveDiscarding(temp_, std::max<std::size_t>(bytes, 1));  // cudaFree waits for its users
    }
    std::size_t bytes = temp_.size();
    device_.check(cub_call(temp_.data(), bytes), "a CUB device-wide call", where);
  }

  void reserveBoxBuffers(std::size_t n) {
    reserveDiscarding(objects_, n);
    reserveEntries(kFirstEntriesPerBox * n);
    pair_room_ = std::max(pair_room_, kFirstPairsPerBox * n);
    reservePairs(pair_room_);
  }

  void reserveEntries(std::size_t entries) {
    if (entries <= keys_[0].size()) return;
    reserveDiscarding(keys_[0], entries);
    const std::size_t room = keys_[0].size();
    reserveDiscarding(keys_[1], room);
    reserveDiscarding(slots_[0], room);
    reserveDiscarding(slots_[1], room);
    reserveDiscarding(offsets_, room + 1);
  }

  // Grows the two pair buffers that do not hold last frame's set (the third
  // grows when its turn comes: pair_room_ remembers).
  void reservePairs(std::size_t pairs) {
    pair_room_ = std::max(pair_room_, pairs);
    for (int role = 1; role <= 2; ++role) {
      reserveDiscarding(pairs_[(previous_ + role) % 3], pair_room_);
    }
  }

  // The room every pair buffer but last frame's has (they are grown together).
  std::size_t pairCapacity() const {
    return std::min(pairs_[(previous_ + 1) % 3].size(), pairs_[(previous_ + 2) % 3].size());
  }

  std::uint32_t maxSlabs() const {
    return std::clamp<std::uint32_t>(slot_count_ / sap::kMinBoxesPerSlab, 1, sap::kMaxGpuSlabs);
  }

  // The frame's search, from the uploaded boxes to the result block's copy:
  // nothing here waits, and every count it passes CUB is a capacity.  Four
  // kernels and five CUB calls; with no last frame no removed selection, with
  // no boxes only that selection and packKernel.
  void enqueueSearch() {
    const std::uint32_t n = slot_count_;
    const std::uint64_t entries = keys_[0].size();
    const std::uint64_t pairs = pairCapacity();
    const std::uint32_t max_slabs = maxSlabs();
    FrameCounters* const counters = counters_.data();
    const int first = (previous_ + 1) % 3;
    const int second = (previous_ + 2) % 3;
    current_ = first;
    // What CUB's temporary sizes depend on: its item counts and bit ranges.
    const CubShape shape{entries, pairs, maxSlabs(),
                         n > 0 ? static_cast<int>(std::bit_width(n)) : -1, last_set_room_};
    sizing_ = shape != cub_shape_;
    if (n > 0) {
      boundsKernel<<<blocksFor(std::max<std::uint64_t>({n, entries, pairs})), kThreadsPerBlock, 0,
                     device_.stream()>>>(objects_.data(), n, counters, keys_[0].data(), entries,
                                         pairs_[first].data(), pairs);
      device_.launched();
      entryKernel<<<blocksFor(n), kThreadsPerBlock, 0, device_.stream()>>>(
          objects_.data(), n, counters, max_slabs, entries, keys_[0].data(), slots_[0].data());
      device_.launched();
      cub::DoubleBuffer<std::uint64_t> keys(keys_[0].data(), keys_[1].data());
      cub::DoubleBuffer<std::uint32_t> slots(slots_[0].data(), slots_[1].data());
      // The slab's bits and the min's top 32 - drop (the kernels' header).
      const int drop = std::bit_width(max_slabs - 1);
      cub([&](void* temp, std::size_t& bytes) {
        return cub::DeviceRadixSort::SortPairs(temp, bytes, keys, slots, entries, drop, 32 + drop,
                                               device_.stream());
      });
      const CandidateCounts counts{.objects = objects_.data(),
                                   .counters = counters,
                                   .sorted_keys = keys.Current(),
                                   .sorted_slots = slots.Current(),
                                   .entries = entries,
                                   .drop = static_cast<unsigned>(drop)};
      cub([&](void* temp, std::size_t& bytes) {
        return cub::DeviceScan::ExclusiveSum(temp, bytes, counts, offsets_.data(), entries + 1,
                                             device_.stream());
      });
      sweepKernel<<<std::max(blocksFor(entries), sweep_blocks_), kThreadsPerBlock, 0,
                    device_.stream()>>>(
          objects_.data(), entries, max_slabs, keys.Current(), slots.Current(), offsets_.data(),
          counters, pairs_[first].data(), static_cast<unsigned long long>(pairs));
      device_.launched();
      cub::DoubleBuffer<IndexPair> pair_buffers(pairs_[first].data(), pairs_[second].data());
      // Slots below n: a and b need bit_width(n) bits each, b all 32 below a's,
      // and kNoPair has every bit set.
      const int pair_bits = 32 + std::bit_width(n);
      cub([&](void* temp, std::size_t& bytes) {
        return cub::DeviceRadixSort::SortKeys(temp, bytes, pair_buffers, pairs, PairBits{}, 0,
                                              pair_bits, device_.stream());
      });
      current_ = pair_buffers.selector == 0 ? first : second;
    }
    // Both sets are searched and selected over their rooms (sorted pairs, then
    // kNoPair), not their counts, so a steady frame's calls take the same
    // arguments every frame but the buffers' rotation.
    this_set_room_ = n > 0 ? pairs : 0;
    const IndexPair* const this_frame = pairs_[current_].data();
    IndexPair* const last_frame = pairs_[previous_].data();
    IndexPair* const free = pairs_[freeBuffer()].data();
    if (this_set_room_ > 0) {
      cub([&](void* temp, std::size_t& bytes) {
        return cub::DeviceSelect::If(temp, bytes, this_frame, free, &counters->added,
                                     static_cast<std::int64_t>(this_set_room_),
                                     NotIn{last_frame, last_set_room_, counters, entries, pairs},
                                     device_.stream());
      });
    }
    if (last_set_room_ > 0) {
      cub([&](void* temp, std::size_t& bytes) {
        return cub::DeviceSelect::If(
            temp, bytes, last_frame, &counters->removed, static_cast<std::int64_t>(last_set_room_),
            NotIn{this_frame, this_set_room_, counters, entries, pairs}, device_.stream());
      });
    }
    packKernel<<<1, kPackThreads, 0, device_.stream()>>>(free, last_frame, counters, block_.data());
    device_.launched();
    device_.record(FinderDevice::kSearched);
    device_.download(host_.data(), block_.data(), sizeof(SapResultBlock));
    device_.record(FinderDevice::kDone);
    cub_shape_ = shape;  // only now: a frame that threw part way sizes again
  }

  // The one of the three pair buffers that is neither last frame's nor this one's.
  int freeBuffer() const { return 3 - previous_ - current_; }

  PairDelta collectDelta() {
    device_.wait(FinderDevice::kDone);
    SapResultBlock& block = *host_.data();
    // Counted on the device, even where the room was too small: a frame past
    // the limit is refused before anything grows for it.
    if (block.counts.pairs > pairLimit()) throw pairLimitError();
    if (spoiled(block.counts.entries, block.counts.pairs, keys_[0].size(), pairCapacity())) {
      // The first run counts too, never the host's time between the runs:
      // the second records the events again, so the first's are read now.
      DeviceWork& work = device_.work();
      work.upload_ms += device_.elapsed(FinderDevice::kStarted, FinderDevice::kUploaded);
      work.kernels_ms += device_.elapsed(FinderDevice::kUploaded, FinderDevice::kSearched);
      work.download_ms += device_.elapsed(FinderDevice::kSearched, FinderDevice::kDone);
      reserveEntries(withHeadroom(block.counts.entries));
      reservePairs(withHeadroom(block.counts.pairs));
      device_.record(FinderDevice::kStarted);  // the boxes are on the device already
      device_.record(FinderDevice::kUploaded);
      enqueueSearch();
      device_.wait(FinderDevice::kDone);
      if (spoiled(block.counts.entries, block.counts.pairs, keys_[0].size(), pairCapacity())) {
        throw std::logic_error("gpusap: a frame outgrew the room its own counts asked for");
      }
    }
    const std::size_t added_count = block.counts.added;
    const std::size_t removed_count = block.counts.removed;
    const std::size_t added_in_head = std::min(added_count, kHeadEntries);
    const std::size_t removed_in_head = std::min(removed_count, kHeadEntries - added_in_head);
    IndexPair* const added_head = block.head[0];
    IndexPair* const removed_head = added_head + added_in_head;
    const IndexPair* added = added_head;
    const IndexPair* removed = removed_head;
    if (added_count + removed_count > kHeadEntries) {
      added = device_.joinHeadAndRest({added_head, added_in_head}, added_count,
                                      pairs_[freeBuffer()].data() + added_in_head, host_added_);
      removed = device_.joinHeadAndRest({removed_head, removed_in_head}, removed_count,
                                        pairs_[previous_].data() + removed_in_head, host_removed_);
      device_.record(FinderDevice::kTailsDone);
      device_.wait(FinderDevice::kTailsDone);
    }
    previous_ = current_;  // nothing below can fail: this frame is now the reference
    last_set_room_ = this_set_room_;
    device_.end();
    return PairDelta{{added, added_count}, {removed, removed_count}};
  }

  // The arguments of a frame's CUB calls that their temporary sizes depend on.
  struct CubShape {
    std::uint64_t entries = 0;
    std::uint64_t pairs = 0;
    std::uint32_t max_slabs = 0;
    int slot_bits = -2;  // bit_width(n), -1 with no boxes; -2: no frame yet
    std::size_t last_set_room = 0;
    friend bool operator==(const CubShape&, const CubShape&) = default;
  };

  FinderDevice device_;  // the stream, events, staging and counted calls
  unsigned sweep_blocks_ = 1;

  std::uint32_t slot_count_ = 0;

  DeviceBuffer<ObjectBounds> objects_;        // ... uploaded, by slot
  DeviceBuffer<std::uint64_t> keys_[2];       // entry keys, and CUB's other half
  DeviceBuffer<std::uint32_t> slots_[2];      // entry slots, and CUB's other half
  DeviceBuffer<unsigned long long> offsets_;  // per entry rank: its candidates' scan
  DeviceBuffer<FrameCounters> counters_;
  DeviceBuffer<SapResultBlock> block_;  // what comes back, assembled on the device
  DeviceBuffer<unsigned char> temp_;    // CUB's temporary storage, shared by its calls
  CubShape cub_shape_;                  // ... sized for the calls of this shape
  bool sizing_ = false;                 // this frame's calls query their sizes
  // pairs_[previous_] holds last frame's sorted pairs, then kNoPair, over
  // last_set_room_ slots (0 before the first frame); the other two are this
  // frame's (current_, this_set_room_ slots) and the sort's other half.
  DeviceBuffer<IndexPair> pairs_[3];
  std::size_t pair_room_ = 0;  // the capacity this frame's two buffers get
  int previous_ = 0;
  int current_ = 1;
  std::size_t last_set_room_ = 0;
  std::size_t this_set_room_ = 0;
  PinnedBuffer<SapResultBlock> host_;
  PinnedBuffer<IndexPair> host_added_;  // whole lists, when longer than the head
  PinnedBuffer<IndexPair> host_removed_;
};

}  // namespace

std::unique_ptr<PairFinder> makeGpuSweepAndPruneFinder(TaskSystem& /*tasks*/) {
  return std::make_unique<GpuSweepAndPruneFinder>();
}

}  // namespace overlap::finders
