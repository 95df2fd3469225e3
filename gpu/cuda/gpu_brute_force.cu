// gpubf: the GPU brute-force pair finder, built so that almost nothing but
// the answer crosses the bus, and so that a warp spends its instructions on
// the boxes, not on finding out which boxes to test.
//
// The bits are laid out in row words (gpu/pairs/row_words.h): one word holds the
// pairs (32 c + lane, b) of one row b.  A warp takes a run of up to 64 rows of
// one column c: it decodes the run's start once, loads box A = 32 c + lane
// into registers once, then per row loads only box B (one address for the
// whole warp), tests, and __ballot_sync gathers the word.  The warp XORs the
// word with last frame's and, when they differ, appends the changed pairs
// (it knows their (a, b), no decode) to an "added" or a "removed" list through
// one atomic per list per word.  The counts keep growing past the lists'
// capacity: an overflow is seen on the host and the changes are collected
// again, from the two frames' words, into longer lists.
//
// The last block of the grid to finish (the one that sees the others' count
// of finished blocks at gridDim.x - 1, after their fences) sorts each list's
// head in place (CUB's block-wide radix sort, two keys a thread when the list
// is short), so the changes come back sorted, from one kernel, and the host
// sorts nothing unless a list outgrew its head.
//
// One frame is: an upload of the boxes from pinned staging (which the caller
// may fill itself: stagingFor()), the one kernel, one copy back of a result
// block holding both counts and the first kHeadEntries of both lists
// (gpu/cuda/launch_shape.h), and the
// four stage events (gpu/cuda/finder_device.h); nothing else unless more changed
// than the block holds.  That chain is a CUDA graph, captured when the sizes,
// buffers or parities it bakes in are new and launched with one call when
// they are as in one of the last two frames (a steady frame: two calls, the
// launch and finish()'s wait).  The kernel zeroes the counts the next
// counting kernel will use (two pairs of counts, used in turn), so no memset
// is queued per frame.
//
// Memory: two word buffers (last frame's, read; this frame's, written) swap
// roles every frame; words past the last row are zero, so growing the slot
// count appends rows that had no overlap.  All buffers live across frames and
// grow geometrically; host buffers are pinned so the copies are asynchronous.
// launch() only enqueues work on the finder's stream; finish() waits on events.
#include <cuda_runtime.h>

#include <algorithm>
#include <bit>
#include <cub/block/block_radix_sort.cuh>
#include <stdexcept>
#include <string>
#include <utility>

#include "gpu/cuda/cuda_buffers.h"
#include "gpu/cuda/finder_device.h"
#include "gpu/cuda/finish_frame.h"
#include "gpu/cuda/launch_shape.h"
#include "gpu/pair_finder.h"
#include "gpu/pairs/row_words.h"

namespace overlap::finders {
namespace {

using pair_logic::kBitsPerWord;
static_assert(kBitsPerWord == kLanes, "a warp's ballot is one row word");

// Each list holds this many entries at first, the head included.
constexpr std::size_t kInitialListCapacity = 1u << 14;
// Blocks of the search kernels resident per multiprocessor, at least: their
// registers are capped to fit (40 a thread at 256 threads from sm_80, 64 on
// sm_75's 1024 threads), which the search needs; the head sort, which would
// take over 100, is a call of its own (OVERLAP_NOINLINE), so only it spills,
// in the one block that runs it.
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ < 800
constexpr unsigned kSearchBlocksPerSm = 4;
#else
constexpr unsigned kSearchBlocksPerSm = 6;
#endif

// What one copy brings back each frame (gpu/cuda/launch_shape.h): the counts
// [pair][0 added, 1 removed], counting kernels using the pairs in turn, each
// zeroing the other for the next (a count may exceed the lists' capacity);
// then the heads, added's (kAdded) and removed's (kRemoved).
enum List : unsigned { kAdded, kRemoved };
using Counts = unsigned long long[2][2];
using GpubfResultBlock = ResultBlock<Counts, 2>;

struct ChangeLists {
  GpubfResultBlock* block;
  unsigned counting;      // the count pair this kernel adds to; it zeroes the other
  IndexPair* added_tail;  // entries from kHeadEntries on
  IndexPair* removed_tail;
  unsigned long long tail_capacity;
  unsigned* blocks_done;  // blocks of this launch that finished; the last sets it back to 0
  unsigned slot_bits;     // every slot is below 2^slot_bits (at least 1, at most 32)
};

// One thread of the grid zeroes the count pair the next counting kernel uses;
// the stream orders that kernel after this one.
__device__ void zeroNextCounts(const ChangeLists& lists) {
  if (blockIdx.x == 0 && threadIdx.x == 0) {
    lists.block->counts[1 - lists.counting][0] = 0;
    lists.block->counts[1 - lists.counting][1] = 0;
  }
}

// Called by all 32 lanes of a warp with the same word, lane k holding its
// pair (a, b); appends the word's changed pairs, each entry written once.
__device__ void appendChanges(std::uint32_t previous, std::uint32_t current, std::uint32_t a,
                              std::uint32_t b, const ChangeLists& lists) {
  const unsigned lane = threadIdx.x % kBitsPerWord;
  const std::uint32_t added = pair_logic::addedBits(previous, current);
  const std::uint32_t removed = pair_logic::removedBits(previous, current);
  unsigned long long* const counts = lists.block->counts[lists.counting];
  unsigned long long added_base = 0;
  unsigned long long removed_base = 0;
  if (lane == 0) {
    if (added != 0)
      added_base = atomicAdd(&counts[0], static_cast<unsigned long long>(__popc(added)));
    if (removed != 0)
      removed_base = atomicAdd(&counts[1], static_cast<unsigned long long>(__popc(removed)));
  }
  added_base = __shfl_sync(kFullWarp, added_base, 0);
  removed_base = __shfl_sync(kFullWarp, removed_base, 0);
  const std::uint32_t lane_bit = 1u << lane;
  const std::uint32_t lanes_below = lane_bit - 1u;
  if ((added | removed) & lane_bit) {
    const bool is_added = (added & lane_bit) != 0;
    const unsigned long long slot = is_added ? added_base + __popc(added & lanes_below)
                                             : removed_base + __popc(removed & lanes_below);
    const IndexPair pair{a, b};
    if (slot < kHeadEntries) {
      lists.block->head[is_added ? kAdded : kRemoved][slot] = pair;
    } else if (slot - kHeadEntries < lists.tail_capacity) {
      (is_added ? lists.added_tail : lists.removed_tail)[slot - kHeadEntries] = pair;
    }
  }
}

// The head sort, by the grid's last block: a list of up to kSmallItems keys
// a thread in one sort, else the whole head, kHeadItems keys a thread.
constexpr unsigned kSmallItems = 2;
constexpr unsigned kHeadItems = kHeadEntries / kThreadsPerBlock;
static_assert(kHeadItems * kThreadsPerBlock == kHeadEntries, "the sort's keys cover the head");
using SmallSort = cub::BlockRadixSort<std::uint64_t, kThreadsPerBlock, kSmallItems>;
using HeadSort = cub::BlockRadixSort<std::uint64_t, kThreadsPerBlock, kHeadItems>;
union SortStorage {
  SmallSort::TempStorage small;
  HeadSort::TempStorage head;
};

// Sorts list[0 .. count) by (a, b), count at most kItems keys a thread.  A
// pair is one key, a above b, each in slot_bits bits, so the sort reads
// 2 * slot_bits bits, not 64.  Keys past the count are all ones, which sort
// last (no pair is one: b > a).
#if defined(OVERLAP_CUDA_EMULATION)
#define OVERLAP_NOINLINE
#else
#define OVERLAP_NOINLINE __noinline__
#endif
template <class Sort, unsigned kItems>
__device__ OVERLAP_NOINLINE void sortList(IndexPair* list, unsigned long long count,
                                          unsigned slot_bits, typename Sort::TempStorage& storage) {
  const std::uint64_t b_mask = (std::uint64_t{1} << slot_bits) - 1;
  std::uint64_t keys[kItems];
  for (unsigned item = 0; item < kItems; ++item) {
    const unsigned i = threadIdx.x * kItems + item;
    keys[item] =
        i < count ? (std::uint64_t{list[i].a} << slot_bits) | list[i].b : ~std::uint64_t{0};
  }
  Sort(storage).Sort(keys, 0, static_cast<int>(2 * slot_bits));
  for (unsigned item = 0; item < kItems; ++item) {
    const unsigned i = threadIdx.x * kItems + item;
    if (i < count) {
      list[i] = IndexPair{static_cast<std::uint32_t>(keys[item] >> slot_bits),
                          static_cast<std::uint32_t>(keys[item] & b_mask)};
    }
  }
}

// Called by every thread of every block once its changes are appended: the
// grid's last block to get here sorts the heads of both lists (a list longer
// than its head is left to the host, which sorts it whole with its tail).
// Each thread fences its own appends before its block counts itself done, so
// the last block sees every block's entries and counts.
__device__ void sortHeadsInLastBlock(const ChangeLists& lists) {
  __shared__ bool last_block;
  __shared__ SortStorage storage;
  __threadfence();
  __syncthreads();
  if (threadIdx.x == 0) last_block = atomicAdd(lists.blocks_done, 1u) == gridDim.x - 1;
  __syncthreads();
  if (!last_block) return;  // uniform across the block
  __threadfence();
  if (threadIdx.x == 0) *lists.blocks_done = 0;  // for the next launch
  for (unsigned which = 0; which < 2; ++which) {
    IndexPair* const list = lists.block->head[which];
    const unsigned long long count =
        *static_cast<volatile unsigned long long*>(&lists.block->counts[lists.counting][which]);
    if (count < 2 || count > kHeadEntries) continue;  // uniform
    if (count <= kSmallItems * kThreadsPerBlock) {
      sortList<SmallSort, kSmallItems>(list, count, lists.slot_bits, storage.small);
    } else {
      sortList<HeadSort, kHeadItems>(list, count, lists.slot_bits, storage.head);
    }
    __syncthreads();  // the storage serves the next list
  }
}

// Calls visit(run, a, first_word) for each non-empty run this warp takes
// (grid-stride), a being this lane's box A and first_word the run's column
// in its first row.
template <class Visit>
__device__ void forEachRun(std::uint32_t n, Visit visit) {
  const std::uint64_t first_warp =
      static_cast<std::uint64_t>(blockIdx.x) * kWarpsPerBlock + threadIdx.x / kBitsPerWord;
  const std::uint64_t warps = static_cast<std::uint64_t>(gridDim.x) * kWarpsPerBlock;
  const unsigned lane = threadIdx.x % kBitsPerWord;
  const std::uint64_t columns = row_words::columnCount(n);
  const std::uint64_t runs = row_words::runCount(n);
  for (std::uint64_t r = first_warp; r < runs; r += warps) {
    const row_words::Run run = row_words::runAt(r, columns, n);
    if (run.first_row >= run.end_row) continue;  // above the diagonal; uniform
    visit(run, static_cast<std::uint32_t>(run.column * kBitsPerWord + lane),
          row_words::rowStart(run.first_row) + run.column);
  }
}

__global__ void __launch_bounds__(kThreadsPerBlock, kSearchBlocksPerSm)
    findPairsKernel(const ObjectBounds* __restrict__ objects, std::uint32_t n,
                    const std::uint32_t* __restrict__ previous_words,
                    std::uint32_t* __restrict__ current_words, ChangeLists lists) {
  zeroNextCounts(lists);
  const bool lane_zero = threadIdx.x % kBitsPerWord == 0;
  forEachRun(n, [&](const row_words::Run& run, std::uint32_t a, std::uint64_t first_word) {
    // Lanes past the last slot test slot 0 and are masked by a < b below.
    const ObjectBounds box_a = objects[a < n ? a : 0];
    // The column's word, stepped row by row.
    const std::uint32_t* previous_word = previous_words + first_word;
    std::uint32_t* current_word = current_words + first_word;
    const auto end_row = static_cast<std::uint32_t>(run.end_row);
    for (auto b = static_cast<std::uint32_t>(run.first_row); b < end_row; ++b) {
      const ObjectBounds box_b = objects[b];  // one address for the whole warp
      const bool pairs = (a < b) & pair_logic::objectsPair(box_a, box_b);
      const std::uint32_t current = __ballot_sync(kFullWarp, pairs);
      const std::uint32_t previous = *previous_word;
      if (lane_zero) *current_word = current;
      if (previous != current) appendChanges(previous, current, a, b, lists);  // uniform
      const std::uint32_t to_next_row = row_words::rowWords(b);  // the same column of row b + 1
      previous_word += to_next_row;
      current_word += to_next_row;
    }
  });
  sortHeadsInLastBlock(lists);
}

// The change collection alone, rerun into longer lists after an overflow.
__global__ void __launch_bounds__(kThreadsPerBlock, kSearchBlocksPerSm)
    collectChangesKernel(std::uint32_t n, const std::uint32_t* __restrict__ previous_words,
                         const std::uint32_t* __restrict__ current_words, ChangeLists lists) {
  zeroNextCounts(lists);
  forEachRun(n, [&](const row_words::Run& run, std::uint32_t a, std::uint64_t word) {
    const auto end_row = static_cast<std::uint32_t>(run.end_row);
    for (auto b = static_cast<std::uint32_t>(run.first_row); b < end_row; ++b) {
      const std::uint32_t previous = previous_words[word];
      const std::uint32_t current = current_words[word];
      if (previous != current) appendChanges(previous, current, a, b, lists);
      word += row_words::rowWords(b);
    }
  });
  sortHeadsInLastBlock(lists);
}

class GpuBruteForceFinder final : public PairFinder {
 public:
  GpuBruteForceFinder() {
    block_ = DeviceBuffer<GpubfResultBlock>(1);
    host_block_ = PinnedBuffer<GpubfResultBlock>(1);
    blocks_done_ = DeviceBuffer<unsigned>(1);
    // Once: from here on each counting kernel zeroes the count pair the next
    // one uses, and its last block sets blocks_done_ back to 0.  The whole
    // block, as every frame copies all of it back (compute-sanitizer's
    // initcheck reports a copy of unwritten memory).
    CUDA_CHECK(cudaMemsetAsync(block_.data(), 0, sizeof(GpubfResultBlock), device_.stream()));
    CUDA_CHECK(cudaMemsetAsync(blocks_done_.data(), 0, sizeof(unsigned), device_.stream()));
    growTails(kInitialListCapacity - kHeadEntries);
  }

  GpuBruteForceFinder(const GpuBruteForceFinder&) = delete;
  GpuBruteForceFinder& operator=(const GpuBruteForceFinder&) = delete;

  std::string_view name() const override { return "gpubf"; }

 private:
  SearchStats searchStats() const override {
    SearchStats stats;
    stats.search_ms = device_.lastMs(FinderDevice::kStarted, FinderDevice::kDone);
    stats.device = device_.lastWorkTimed();
    return stats;
  }

  std::span<ObjectBounds> staging(std::size_t count) override { return device_.stagingRoom(count); }

  // Grows what the frame needs first (a capture refuses allocations), then
  // enqueues the frame's chain: a graph launch when it is as in one of the
  // last two frames.
  void startSearch(std::span<const ObjectBounds> objects,
                   const std::span<const std::uint32_t>* /*changed*/) override {
    device_.begin();
    slot_count_ = checkedSlotCount(name(), slot_count_, objects.size());
    growWords(row_words::wordCount(slot_count_));
    reserveDiscarding(objects_, objects.size());
    device_.stage(objects);
    reading_ = counting_;
    const bool searches = row_words::runCount(slot_count_) > 0;
    const ChangeLists lists = changeLists();
    const auto as_key = [](const void* pointer) {
      return reinterpret_cast<std::uintptr_t>(pointer);
    };
    device_.enqueueChain(
        {slot_count_, as_key(objects_.data()), as_key(words_[previous_].data()),
         as_key(words_[1 - previous_].data()), as_key(block_.data()), as_key(host_block_.data()),
         lists.counting, as_key(lists.added_tail), as_key(lists.removed_tail),
         static_cast<std::uintptr_t>(lists.tail_capacity), as_key(lists.blocks_done)},
        [&] {
          device_.record(FinderDevice::kStarted);
          device_.upload(objects_.data(), objects.size());
          device_.record(FinderDevice::kUploaded);
          if (searches) {
            findPairsKernel<<<searchBlocks(), kThreadsPerBlock, 0, device_.stream()>>>(
                objects_.data(), slot_count_, words_[previous_].data(),
                words_[1 - previous_].data(), lists);
            device_.launched();
          }
          device_.record(FinderDevice::kSearched);
          enqueueBlockCopy();
          device_.record(FinderDevice::kDone);
        });
    if (searches) counting_ = 1 - counting_;
  }

  // The frame ends here whether this returns or throws.  After a throw no work
  // of it stays queued, and previous_ still names the last frame the caller
  // received a delta for, so the next frame's delta is taken against it.
  PairDelta finishSearch() override {
    return finishFrame(device_.stream(), [&] { return collectDelta(); });
  }

  PairDelta collectDelta() {
    device_.wait(FinderDevice::kDone);
    std::size_t added_count = host_block_.data()->counts[reading_][0];
    std::size_t removed_count = host_block_.data()->counts[reading_][1];
    IndexPair* head_added = host_block_.data()->head[kAdded];
    IndexPair* head_removed = host_block_.data()->head[kRemoved];
    IndexPair* added = head_added;
    IndexPair* removed = head_removed;
    // Counted on the device: a frame past the limit is refused before its
    // lists are fetched, or grown for.
    if (added_count > pairLimit()) throw pairLimitError();
    if (std::max(added_count, removed_count) > kHeadEntries) {
      // More changes than the block holds: fetch the tails too, as part of
      // the copy back (the done event is recorded again after them).
      const std::size_t needed = std::max(added_count, removed_count) - kHeadEntries;
      if (needed > added_tail_.size()) recollectChanges(needed);
      added = device_.joinHeadAndRest({head_added, std::min(added_count, kHeadEntries)},
                                      added_count, added_tail_.data(), host_added_);
      removed = device_.joinHeadAndRest({head_removed, std::min(removed_count, kHeadEntries)},
                                        removed_count, removed_tail_.data(), host_removed_);
      device_.record(FinderDevice::kDone);
      device_.wait(FinderDevice::kDone);
    }
    previous_ = 1 - previous_;  // nothing below can fail: this frame is now the reference

    // The device sorted every head that held its whole list; a list longer
    // than its head came back in atomic order.
    for (const auto& [list, count] :
         {std::pair{added, added_count}, std::pair{removed, removed_count}}) {
      if (count <= kHeadEntries) continue;
      std::sort(list, list + count);
      device_.work().host_entries_sorted += count;
    }
    device_.end();
    return PairDelta{{added, added_count}, {removed, removed_count}};
  }

  ChangeLists changeLists() const {
    // Every slot is below 2^bits: the keys' width (at least 1, at most 32).
    const auto slot_bits = std::max(1u, static_cast<unsigned>(std::bit_width(slot_count_)));
    return ChangeLists{block_.data(),
                       counting_,
                       added_tail_.data(),
                       removed_tail_.data(),
                       std::min(added_tail_.size(), removed_tail_.size()),
                       blocks_done_.data(),
                       slot_bits};
  }

  unsigned searchBlocks() const {
    return blocksFor(row_words::runCount(slot_count_), kWarpsPerBlock);
  }

  void enqueueBlockCopy() {
    device_.download(host_block_.data(), block_.data(), sizeof(GpubfResultBlock));
  }

  // Both tails are replaced only once both exist: they share one capacity.
  void growTails(std::size_t needed) {
    const std::size_t capacity = std::max(needed, 2 * added_tail_.size());
    DeviceBuffer<IndexPair> added(capacity);
    DeviceBuffer<IndexPair> removed(capacity);
    added_tail_ = std::move(added);
    removed_tail_ = std::move(removed);
  }

  // Both word buffers cover `words`: the one previous_ names keeps last
  // frame's words, every other word is zero.  New buffers are filled before
  // they replace the old ones, so a throw leaves the old ones in place.
  void growWords(std::uint64_t words) {
    if (words > words_[0].size()) {
      const std::size_t capacity = std::max<std::size_t>(words, 2 * words_[0].size());
      DeviceBuffer<std::uint32_t> last_frame(capacity);
      DeviceBuffer<std::uint32_t> this_frame(capacity);
      const cudaStream_t stream = device_.stream();
      CUDA_CHECK(cudaMemsetAsync(last_frame.data(), 0, capacity * sizeof(std::uint32_t), stream));
      CUDA_CHECK(cudaMemsetAsync(this_frame.data(), 0, capacity * sizeof(std::uint32_t), stream));
      if (word_count_ > 0) {
        CUDA_CHECK(cudaMemcpyAsync(last_frame.data(), words_[previous_].data(),
                                   word_count_ * sizeof(std::uint32_t), cudaMemcpyDeviceToDevice,
                                   stream));
      }
      // The copy reads the old buffer, freed below.  Growth is rare: waiting costs nothing.
      CUDA_CHECK(cudaStreamSynchronize(stream));
      words_[previous_] = std::move(last_frame);
      words_[1 - previous_] = std::move(this_frame);
    }
    word_count_ = words;
  }

  // The kernel counted `needed` tail entries on one list but stored only what
  // fit: collect the changes again from the two frames' words into tails that
  // fit them, and bring the block back again with the new counts.
  void recollectChanges(std::size_t needed) {
    growTails(needed);
    reading_ = counting_;
    collectChangesKernel<<<searchBlocks(), kThreadsPerBlock, 0, device_.stream()>>>(
        slot_count_, words_[previous_].data(), words_[1 - previous_].data(), changeLists());
    device_.launched();
    counting_ = 1 - counting_;
    enqueueBlockCopy();
    device_.record(FinderDevice::kDone);
    device_.wait(FinderDevice::kDone);
  }

  FinderDevice device_;  // the stream, events, staging, counted calls and graphs

  std::uint32_t slot_count_ = 0;
  std::uint64_t word_count_ = 0;

  DeviceBuffer<ObjectBounds> objects_;  // this frame's boxes, uploaded from the staging
  // One bit per pair: words_[previous_] holds the last finished frame's, the
  // other the frame being searched (or last searched, if finish() threw).
  DeviceBuffer<std::uint32_t> words_[2];
  int previous_ = 0;
  DeviceBuffer<GpubfResultBlock> block_;
  PinnedBuffer<GpubfResultBlock> host_block_;
  DeviceBuffer<unsigned> blocks_done_;
  unsigned counting_ = 0;                 // the count pair the next counting kernel adds to
  unsigned reading_ = 0;                  // ... and the one the block copied back holds
  DeviceBuffer<IndexPair> added_tail_;    // entries from kHeadEntries on, in atomic order
  DeviceBuffer<IndexPair> removed_tail_;  // ... same capacity as added_tail_
  PinnedBuffer<IndexPair> host_added_;    // whole lists, when longer than the head
  PinnedBuffer<IndexPair> host_removed_;
};

}  // namespace

std::unique_ptr<PairFinder> makeGpuBruteForceFinder(TaskSystem& /*tasks*/) {
  return std::make_unique<GpuBruteForceFinder>();
}

}  // namespace overlap::finders
