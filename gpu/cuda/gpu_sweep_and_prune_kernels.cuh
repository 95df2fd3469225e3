// gpusap's kernels and device helpers (included by gpu/cuda/gpu_sweep_and_prune.cu
// only): the frame's bounds and the fill of its empty slots, the entries and
// their sort keys, each entry's candidate count (read by the scan), the
// balanced sweep, the pair-set helpers the CUB sort and selections use, and
// the packing of the frame's result block.
//
// Rules the kernels share, each with its reason:
// - A box is swept only if it can pair: no NaN coordinate (NaN compares false
//   on every test) and group != 0 and mask != 0 (a zero filter accepts
//   nothing: unused slots).  The others get no entry.
// - Axes: the sweep axis is the one whose swept centres spread widest, the
//   slab axis the wider of the other two.  The slab axis is cut into slabs
//   (sap::SlabGrid, cpusap's) three mean box extents wide
//   (sap::chooseSweepAxes), at most one per kMinBoxesPerSlab boxes and at
//   most the host's `max_slabs`.  Every thread derives the same axes and
//   grid from the frame's counters.
// - A box has one entry per slab its hull on the slab axis reaches (min and
//   max taken in either order: pair_logic's test passes an inverted interval
//   only against one that contains its max, inside the hull).  Two boxes
//   that pass the slab axis' test share the slabs between their hulls'
//   starts; the pair is reported only in the first of them, the one where
//   one of the two hulls starts, so it is found exactly once.
// - An entry's key is its slab in the high 32 bits and the ordered bits of
//   the box's min on the sweep axis, -0 read as +0 (-0 == +0 as floats, and
//   an order that split them would miss a box starting at +0 against one
//   ending at -0), in the low.  Entry slots the frame leaves empty hold
//   kNoEntry (boundsKernel fills every slot first), above every key, so they
//   sort last and fall in no candidate range.  A box takes its entries'
//   places by one atomic add a warp: the places vary from run to run, but the
//   sort orders entries by key, and entries with equal keys find the same
//   pairs in either order (each pair once, by whichever comes first), so the
//   sorted pair set is the same every run.
// - The sort orders entries by their keys' bits from `drop` up, drop = the
//   slab's bit width, so that the bits sorted fit 32 (four radix passes, not
//   six): a key read so (key >> drop, its sort key) is monotone in the key,
//   and the slab keeps all its bits.
// - Sorted so, entry r pairs only with entries after it whose sort key is at
//   most that of (its slab, the key of its box's max): ranks r + 1 ..
//   upper_bound - 1, its candidates, all in its slab.  A box l after r that
//   meets r's box on the sweep axis starts at most at r's max, so its sort
//   key is at most r's end (monotone), and it is in that range; the earlier
//   of two boxes finds the later, so each pair once.  Every candidate gets
//   pair_logic's full test, so the pairs are exactly the brute force's (the
//   dropped bits only add candidates: boxes starting within 2^(drop - 23)
//   of the magnitude of r's max past it).
// - Candidate t (0 .. total) belongs to the rank r with offset[r] <= t <
//   offset[r + 1] (an exclusive scan of the counts): the sweep hands out
//   candidates, not entries, so one long box spreads over many warps.
// - Counts that outgrow the host's capacities (entries, pairs) are still
//   counted; such a frame is spoiled: its selections select nothing (last
//   frame's set stays whole), and the host runs the frame again with room.
// - Pairs are IndexPairs from the sweep to the host (a < b), sorted by CUB
//   through PairBits, (a, b) as one key; slots past the frame's pairs hold
//   kNoPair, above every real pair in the bits sorted.
// - The counters are zero when a frame starts: the finder zeroes them once,
//   and every frame's last kernel (packKernel, one block) zeroes them after
//   it has read them.
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <cstdint>
#include <cuda/std/tuple>
#include <iterator>
#include <type_traits>

#include "gpu/cuda/launch_shape.h"
#include "gpu/pairs/pair_logic.h"
#include "gpu/pairs/sap_sweep.h"

namespace overlap::finders::sap_kernels {

// Each warp takes this many candidates at a time, 32 consecutive per step.
inline constexpr unsigned kStepsPerWarp = 8;
inline constexpr std::uint64_t kWarpSpan = kLanes * kStepsPerWarp;
inline constexpr std::uint32_t kNoKey = 0xFFFFFFFFu;
// An entry slot the frame left empty, and a pair-buffer slot past the
// frame's pairs: all ones, above every real key in any bit range sorted.
inline constexpr std::uint64_t kNoEntry = ~std::uint64_t{0};
inline constexpr std::uint32_t kNoSlot = 0xFFFFFFFFu;  // both slots of kNoPair
// packKernel's one block: it copies at most kHeadEntries pairs.
inline constexpr unsigned kPackThreads = 1024;

// Per frame, on the device, zero at its start: what the kernels count.
// centre_bounds holds, per axis, the complement of the ordered bits of the
// least centre and the ordered bits of the greatest, both raised by
// atomicMax from 0 (0 on both reads as NaN: no finite centre).
struct FrameCounters {
  std::uint32_t centre_bounds[3][2];
  unsigned long long finite_boxes;  // swept boxes with every coordinate finite
  double extent_sum[3];             // their extents, per axis
  unsigned long long entries;       // wanted; may exceed the entry capacity
  std::uint32_t sweep_axis;         // the frame's, set by entryKernel for the scan
  unsigned long long pairs;         // found; may exceed the pair capacity
  unsigned long long added;
  unsigned long long removed;
};

// What comes back to the host, in one copy (gpu/cuda/launch_shape.h): the
// counts, then one head of the changes, added's first min(added,
// kHeadEntries), then as many of removed's as fit.
struct SapCounts {
  unsigned long long entries;
  unsigned long long pairs;
  unsigned long long added;
  unsigned long long removed;
};
using SapResultBlock = ResultBlock<SapCounts, 1>;

using sap::fromOrderedKey;
using sap::orderedKey;

__host__ __device__ inline bool swept(const ObjectBounds& box) {
  bool nan = false;
  for (int axis = 0; axis < 3; ++axis)
    nan |= (box.min[axis] != box.min[axis]) | (box.max[axis] != box.max[axis]);
  return !nan & (box.group != 0) & (box.mask != 0);
}

// The slabs a swept box's hull on the slab axis reaches.
struct SlabRange {
  std::uint32_t first;
  std::uint32_t last;
};

__host__ __device__ inline SlabRange slabsOf(const sap::SweepAxes& axes, const ObjectBounds& box) {
  const float a = box.min[axes.slab];
  const float b = box.max[axes.slab];
  return {axes.grid.slabOf(a < b ? a : b), axes.grid.slabOf(a < b ? b : a)};
}

// The frame's axes and slabs, from its counters (sap::chooseSweepAxes).
__host__ __device__ inline sap::SweepAxes frameAxes(const FrameCounters& counters,
                                                    std::uint32_t max_slabs) {
  float lowest[3];
  float highest[3];
  for (int axis = 0; axis < 3; ++axis) {
    lowest[axis] = fromOrderedKey(~counters.centre_bounds[axis][0]);
    highest[axis] = fromOrderedKey(counters.centre_bounds[axis][1]);
  }
  return sap::chooseSweepAxes(lowest, highest, counters.extent_sum, counters.finite_boxes,
                              max_slabs);
}

// The first index in [first, last) whose value exceeds `value`, values read
// from bit `drop` up and sorted so.
template <class T>
__host__ __device__ inline std::uint64_t upperBound(const T* values, std::uint64_t first,
                                                    std::uint64_t last,
                                                    std::type_identity_t<T> value,
                                                    unsigned drop = 0) {
  while (first < last) {
    const std::uint64_t middle = first + (last - first) / 2;
    if ((values[middle] >> drop) <= (value >> drop)) {
      first = middle + 1;
    } else {
      last = middle;
    }
  }
  return first;
}

// Every kernel here runs kThreadsPerBlock threads a block.
__device__ inline std::uint64_t globalThread() {
  return static_cast<std::uint64_t>(blockIdx.x) * kThreadsPerBlock + threadIdx.x;
}

__device__ inline std::uint64_t gridThreads() {
  return static_cast<std::uint64_t>(gridDim.x) * kThreadsPerBlock;
}

template <class T>
__device__ inline T warpSum(T value) {
  for (int offset = 16; offset > 0; offset /= 2) value += __shfl_xor_sync(kFullWarp, value, offset);
  return value;
}

// The least and greatest finite centre of the swept boxes on each axis, and
// the count and extents of the swept boxes with every coordinate finite; and
// every entry slot set to kNoEntry and every pair slot to kNoPair, so that
// the slots the frame leaves empty sort last.
__global__ void __launch_bounds__(kThreadsPerBlock)
    boundsKernel(const ObjectBounds* __restrict__ objects, std::uint32_t n,
                 FrameCounters* __restrict__ counters, std::uint64_t* __restrict__ entry_keys,
                 std::uint64_t entry_capacity, IndexPair* __restrict__ pairs,
                 std::uint64_t pair_capacity) {
  std::uint32_t low[3] = {kNoKey, kNoKey, kNoKey};
  std::uint32_t high[3] = {0, 0, 0};
  unsigned long long finite = 0;
  double extents[3] = {0, 0, 0};
  for (std::uint64_t i = globalThread(); i < entry_capacity; i += gridThreads()) {
    entry_keys[i] = kNoEntry;
  }
  for (std::uint64_t i = globalThread(); i < pair_capacity; i += gridThreads()) {
    pairs[i] = IndexPair{kNoSlot, kNoSlot};  // kNoPair
  }
  for (std::uint64_t i = globalThread(); i < n; i += gridThreads()) {
    const ObjectBounds box = objects[i];
    if (!swept(box)) continue;
    bool all_finite = true;
    for (int axis = 0; axis < 3; ++axis) {
      all_finite &=
          (box.min[axis] - box.min[axis] == 0.0f) & (box.max[axis] - box.max[axis] == 0.0f);
      const float centre = 0.5f * box.min[axis] + 0.5f * box.max[axis];
      if (!(centre - centre == 0.0f)) continue;  // infinite (or NaN from -inf + inf)
      const std::uint32_t key = orderedKey(centre);
      low[axis] = low[axis] < key ? low[axis] : key;
      high[axis] = high[axis] > key ? high[axis] : key;
    }
    if (!all_finite) continue;
    ++finite;
    for (int axis = 0; axis < 3; ++axis) extents[axis] += double{box.max[axis]} - box.min[axis];
  }
  // Every lane of the (full) warp gets here: reduce across it, then one atomic each.
  for (int axis = 0; axis < 3; ++axis) {
    for (int offset = 16; offset > 0; offset /= 2) {
      const std::uint32_t other_low = __shfl_xor_sync(kFullWarp, low[axis], offset);
      const std::uint32_t other_high = __shfl_xor_sync(kFullWarp, high[axis], offset);
      low[axis] = low[axis] < other_low ? low[axis] : other_low;
      high[axis] = high[axis] > other_high ? high[axis] : other_high;
    }
    extents[axis] = warpSum(extents[axis]);
  }
  finite = warpSum(finite);
  if (threadIdx.x % kLanes != 0) return;
  for (int axis = 0; axis < 3; ++axis) {
    atomicMax(&counters->centre_bounds[axis][0], ~low[axis]);
    atomicMax(&counters->centre_bounds[axis][1], high[axis]);
    if (finite != 0) atomicAdd(&counters->extent_sum[axis], extents[axis]);
  }
  if (finite != 0) atomicAdd(&counters->finite_boxes, finite);
}

// Writes each swept box's entries (those that fit in `capacity`) at places
// its warp takes with one atomic add, and counts the entries wanted.
__global__ void __launch_bounds__(kThreadsPerBlock)
    entryKernel(const ObjectBounds* __restrict__ objects, std::uint32_t n,
                FrameCounters* __restrict__ counters, std::uint32_t max_slabs,
                std::uint64_t capacity, std::uint64_t* __restrict__ keys,
                std::uint32_t* __restrict__ slots) {
  const sap::SweepAxes axes = frameAxes(*counters, max_slabs);
  if (globalThread() == 0) counters->sweep_axis = static_cast<std::uint32_t>(axes.sweep);
  const unsigned lane = threadIdx.x % kLanes;
  // i - lane is the same in the whole warp, so every lane stays for the collectives.
  for (std::uint64_t i = globalThread(); i - lane < n; i += gridThreads()) {
    SlabRange slabs{1, 0};  // none
    if (i < n && swept(objects[i])) slabs = slabsOf(axes, objects[i]);
    const unsigned long long span = slabs.last + 1 - slabs.first;
    unsigned long long before = span;  // this lane's inclusive prefix, then exclusive
    for (int offset = 1; offset < static_cast<int>(kLanes); offset *= 2) {
      const unsigned long long other = __shfl_up_sync(kFullWarp, before, offset);
      if (static_cast<int>(lane) >= offset) before += other;
    }
    const unsigned long long warp_total = __shfl_sync(kFullWarp, before, kLanes - 1);
    before -= span;
    unsigned long long first = 0;
    if (lane == 0 && warp_total != 0) first = atomicAdd(&counters->entries, warp_total);
    std::uint64_t entry = __shfl_sync(kFullWarp, first, 0) + before;
    if (span == 0) continue;
    const std::uint64_t min_key = orderedKey(objects[i].min[axes.sweep]);
    for (std::uint32_t slab = slabs.first; slab <= slabs.last && entry < capacity;
         ++slab, ++entry) {
      keys[entry] = (std::uint64_t{slab} << 32) | min_key;
      slots[entry] = static_cast<std::uint32_t>(i);
    }
  }
}

// The candidates of the entry at each rank, computed where the scan that
// hands them out reads them (CUB's input iterator): the entries after it in
// its slab that start inside its extent on the sweep axis, up to the first
// key above (its slab, the key of its max).  Rank `entries` reads 0, so that
// the exclusive scan of entries + 1 counts ends in the total.
struct CandidateCounts {
  using value_type = unsigned long long;
  using difference_type = std::ptrdiff_t;
  using pointer = const value_type*;
  using reference = value_type;
  using iterator_category = std::random_access_iterator_tag;

  const ObjectBounds* objects;
  const FrameCounters* counters;
  const std::uint64_t* sorted_keys;
  const std::uint32_t* sorted_slots;
  std::uint64_t entries;
  unsigned drop;  // the sort's begin bit
  std::uint64_t rank = 0;

  __host__ __device__ value_type operator[](difference_type offset) const {
    const std::uint64_t r = rank + static_cast<std::uint64_t>(offset);
    if (r >= entries || sorted_keys[r] == kNoEntry) return 0;
    const std::uint64_t slab = sorted_keys[r] >> 32;
    const std::uint64_t end_key =
        (slab << 32) | orderedKey(objects[sorted_slots[r]].max[counters->sweep_axis]);
    return upperBound(sorted_keys, r + 1, entries, end_key, drop) - r - 1;
  }
  __host__ __device__ value_type operator*() const { return (*this)[0]; }
  __host__ __device__ CandidateCounts operator+(difference_type offset) const {
    CandidateCounts moved = *this;
    moved.rank += static_cast<std::uint64_t>(offset);
    return moved;
  }
  __host__ __device__ CandidateCounts& operator+=(difference_type offset) {
    rank += static_cast<std::uint64_t>(offset);
    return *this;
  }
  __host__ __device__ CandidateCounts& operator++() { return *this += 1; }
  __host__ __device__ difference_type operator-(const CandidateCounts& other) const {
    return static_cast<difference_type>(rank - other.rank);
  }
};

// Tests every candidate (owner rank r, candidate rank j) and appends the
// pairs, one atomic per warp step.  Pairs past `capacity` are counted, not
// stored.
__global__ void __launch_bounds__(kThreadsPerBlock)
    sweepKernel(const ObjectBounds* __restrict__ objects, std::uint64_t entries,
                std::uint32_t max_slabs, const std::uint64_t* __restrict__ sorted_keys,
                const std::uint32_t* __restrict__ sorted_slots,
                const unsigned long long* __restrict__ offsets,
                FrameCounters* __restrict__ counters, IndexPair* __restrict__ pairs,
                unsigned long long capacity) {
  const sap::SweepAxes axes = frameAxes(*counters, max_slabs);
  const unsigned long long total = offsets[entries];
  const unsigned lane = threadIdx.x % kLanes;
  const std::uint64_t first_warp = globalThread() / kLanes;
  const std::uint64_t warps = gridThreads() / kLanes;
  for (std::uint64_t base = first_warp * kWarpSpan; base < total; base += warps * kWarpSpan) {
    // This lane's owner for its first candidate; later ones only move it forward.
    std::uint64_t owner = upperBound(offsets, 0, entries + 1, base + lane) - 1;
    for (unsigned step = 0; step < kStepsPerWarp; ++step) {  // uniform across the warp
      const std::uint64_t t = base + step * kLanes + lane;
      bool found = false;
      std::uint32_t a = 0;
      std::uint32_t b = 0;
      if (t < total) {
        if (offsets[owner + 1] <= t) owner = upperBound(offsets, owner + 1, entries + 1, t) - 1;
        const std::uint64_t candidate = owner + 1 + (t - offsets[owner]);
        a = sorted_slots[owner];
        b = sorted_slots[candidate];
        const ObjectBounds box_a = objects[a];
        const ObjectBounds box_b = objects[b];
        const auto slab = static_cast<std::uint32_t>(sorted_keys[owner] >> 32);
        // Reported only in the first slab both reach: where one of them starts.
        found = pair_logic::objectsPair(box_a, box_b) &
                ((slabsOf(axes, box_a).first == slab) | (slabsOf(axes, box_b).first == slab));
      }
      const unsigned ballot = __ballot_sync(kFullWarp, found);
      if (ballot == 0) continue;  // uniform
      unsigned long long first = 0;
      if (lane == 0)
        first = atomicAdd(&counters->pairs, static_cast<unsigned long long>(__popc(ballot)));
      first = __shfl_sync(kFullWarp, first, 0);
      const unsigned long long slot = first + __popc(ballot & ((1u << lane) - 1u));
      if (found && slot < capacity) pairs[slot] = a < b ? IndexPair{a, b} : IndexPair{b, a};
    }
  }
}

// CUB's radix sort of IndexPairs (its decomposer): a, then b, as one key.
struct PairBits {
  __host__ __device__ ::cuda::std::tuple<std::uint32_t&, std::uint32_t&> operator()(
      IndexPair& pair) const {
    return ::cuda::std::tie(pair.a, pair.b);
  }
};

__host__ __device__ inline bool pairLess(const IndexPair& x, const IndexPair& y) {
  return x.a < y.a || (x.a == y.a && x.b < y.b);
}

__host__ __device__ inline bool samePair(const IndexPair& x, const IndexPair& y) {
  return x.a == y.a && x.b == y.b;
}

// Whether the frame outgrew the host's capacities: then its pairs are not all there.
__host__ __device__ inline bool spoiled(std::uint64_t entries, std::uint64_t pairs,
                                        std::uint64_t entry_capacity, std::uint64_t pair_capacity) {
  return entries > entry_capacity || pairs > pair_capacity;
}

// The selection rule of the frame's changes: a real pair not in a sorted set
// (whose tail may be kNoPair), and nothing at all in a spoiled frame.
struct NotIn {
  const IndexPair* set;
  std::uint64_t count;
  const FrameCounters* counters;
  std::uint64_t entry_capacity;
  std::uint64_t pair_capacity;
  __host__ __device__ bool operator()(const IndexPair& pair) const {
    if ((pair.a == kNoSlot && pair.b == kNoSlot) ||  // kNoPair
        spoiled(counters->entries, counters->pairs, entry_capacity, pair_capacity))
      return false;
    std::uint64_t first = 0;  // the first element of the set not below `pair`
    std::uint64_t last = count;
    while (first < last) {
      const std::uint64_t middle = first + (last - first) / 2;
      if (pairLess(set[middle], pair)) {
        first = middle + 1;
      } else {
        last = middle;
      }
    }
    return first == count || !samePair(set[first], pair);
  }
};

// The frame's last kernel, one block of kPackThreads: fills the result block
// (the counts and the lists' heads, added's then removed's), then zeroes the
// counters for the next frame.
__global__ void __launch_bounds__(kPackThreads)
    packKernel(const IndexPair* __restrict__ added, const IndexPair* __restrict__ removed,
               FrameCounters* __restrict__ counters, SapResultBlock* __restrict__ block) {
  const unsigned long long added_count = counters->added;
  const unsigned long long removed_count = counters->removed;
  if (threadIdx.x == 0) {
    block->counts = SapCounts{counters->entries, counters->pairs, added_count, removed_count};
  }
  for (std::uint64_t i = threadIdx.x; i < kHeadEntries; i += kPackThreads) {
    if (i < added_count) {
      block->head[0][i] = added[i];
    } else if (i - added_count < removed_count) {
      block->head[0][i] = removed[i - added_count];
    }
  }
  __syncthreads();  // every thread has read the counts
  if (threadIdx.x == 0) *counters = FrameCounters{};
}

}  // namespace overlap::finders::sap_kernels
