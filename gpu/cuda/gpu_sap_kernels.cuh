// gpusap's kernels and device helpers (included by gpu/cuda/gpu_sap_pair_finder.cu
// only): the axes and slabs, the entries and their sort keys, each entry's
// candidate count, the balanced sweep, the pair-set helpers the CUB
// selections use, and the packing of the frame's result block.
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
//   ending at -0), in the low.  Entries past the frame's count are kNoEntry,
//   above every key, so they sort last and fall in no candidate range.
// - Sorted by key, entry r pairs only with entries after it whose key is at
//   most (its slab, the key of its box's max): ranks r + 1 .. upper_bound - 1,
//   its candidates, all in its slab.  The other half of the sweep axis' test
//   holds by the order; every candidate gets pair_logic's full test, so the
//   pairs are exactly the brute force's.
// - Candidate t (0 .. total) belongs to the rank r with offset[r] <= t <
//   offset[r + 1] (an exclusive scan of the counts): the sweep hands out
//   candidates, not entries, so one long box spreads over many warps.
// - Counts that outgrow the host's capacities (entries, pairs) are still
//   counted; such a frame is spoiled: its selections select nothing (last
//   frame's set stays whole), and the host runs the frame again with room.
#pragma once

#include <cuda_runtime.h>
#include <string.h>  // ::memcpy, which device code may call too

#include <cstdint>
#include <type_traits>

#include "gpu/pairs/pair_logic.h"
#include "gpu/pairs/sap_sweep.h"

namespace overlap::finders::sap_kernels {

inline constexpr unsigned kThreadsPerBlock = 256;
inline constexpr unsigned kFullWarp = 0xFFFFFFFFu;
inline constexpr unsigned kLanes = 32;
// Each warp takes this many candidates at a time, 32 consecutive per step.
inline constexpr unsigned kStepsPerWarp = 8;
inline constexpr std::uint64_t kWarpSpan = kLanes * kStepsPerWarp;
inline constexpr std::uint32_t kNoKey = 0xFFFFFFFFu;
// An entry slot the frame left empty, and a pair-buffer slot past the
// frame's pairs: all ones, above every real key in any bit range sorted.
inline constexpr std::uint64_t kNoEntry = ~std::uint64_t{0};
inline constexpr std::uint64_t kNoPair = ~std::uint64_t{0};
// The entries of the changes that come back in the result block, added's
// first, then removed's: a frame that changes fewer pairs (the common case)
// needs no further copy.  32 KiB.
inline constexpr std::uint32_t kHeadEntries = 1u << 12;

// Per frame, on the device, zeroed by one memset: what the kernels count.
// centre_bounds holds, per axis, the complement of the ordered bits of the
// least centre and the ordered bits of the greatest, both raised by
// atomicMax from 0 (0 on both reads as NaN: no finite centre).
struct FrameCounters {
  std::uint32_t centre_bounds[3][2];
  unsigned long long finite_boxes;  // swept boxes with every coordinate finite
  double extent_sum[3];             // their extents, per axis
  unsigned long long entries;       // wanted; may exceed the entry capacity
  unsigned long long pairs;         // found; may exceed the pair capacity
  unsigned long long added;
  unsigned long long removed;
};

// What comes back to the host, in one copy: the counts, then the changes'
// heads (added's first min(added, kHeadEntries), then as many of removed's
// as fit), as IndexPairs.
struct ResultBlock {
  unsigned long long entries;
  unsigned long long pairs;
  unsigned long long added;
  unsigned long long removed;
  IndexPair head[kHeadEntries];
};

__host__ __device__ inline std::uint32_t orderedKey(float value) {
  std::uint32_t bits = 0;
  ::memcpy(&bits, &value, sizeof bits);
  if (bits == 0x80000000u) bits = 0;  // -0 is +0
  return bits ^ ((bits >> 31) != 0 ? 0xFFFFFFFFu : 0x80000000u);
}

__host__ __device__ inline float fromOrderedKey(std::uint32_t key) {
  const std::uint32_t bits = key ^ ((key >> 31) != 0 ? 0x80000000u : 0xFFFFFFFFu);
  float value = 0;
  ::memcpy(&value, &bits, sizeof value);
  return value;
}

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

// The first index in [first, last) whose value exceeds `value`; values sorted.
template <class T>
__host__ __device__ inline std::uint64_t upperBound(const T* values, std::uint64_t first,
                                                    std::uint64_t last,
                                                    std::type_identity_t<T> value) {
  while (first < last) {
    const std::uint64_t middle = first + (last - first) / 2;
    if (values[middle] <= value) {
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
// the count and extents of the swept boxes with every coordinate finite.
__global__ void __launch_bounds__(kThreadsPerBlock)
    boundsKernel(const ObjectBounds* __restrict__ objects, std::uint32_t n,
                 FrameCounters* __restrict__ counters) {
  std::uint32_t low[3] = {kNoKey, kNoKey, kNoKey};
  std::uint32_t high[3] = {0, 0, 0};
  unsigned long long finite = 0;
  double extents[3] = {0, 0, 0};
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

// spans[i] = the entries of box i; spans[n] = 0, so that the exclusive scan
// of n + 1 spans ends in the total.
__global__ void __launch_bounds__(kThreadsPerBlock)
    spanKernel(const ObjectBounds* __restrict__ objects, std::uint32_t n,
               const FrameCounters* __restrict__ counters, std::uint32_t max_slabs,
               unsigned long long* __restrict__ spans) {
  const sap::SweepAxes axes = frameAxes(*counters, max_slabs);
  for (std::uint64_t i = globalThread(); i <= n; i += gridThreads()) {
    unsigned long long span = 0;
    if (i < n && swept(objects[i])) {
      const SlabRange slabs = slabsOf(axes, objects[i]);
      span = slabs.last - slabs.first + 1;
    }
    spans[i] = span;
  }
}

// Writes each box's entries at its scanned offset (those that fit in
// `capacity`), kNoEntry after the last, and the count wanted.
__global__ void __launch_bounds__(kThreadsPerBlock)
    entryKernel(const ObjectBounds* __restrict__ objects, std::uint32_t n,
                FrameCounters* __restrict__ counters, std::uint32_t max_slabs,
                const unsigned long long* __restrict__ first_entry, std::uint64_t capacity,
                std::uint64_t* __restrict__ keys, std::uint32_t* __restrict__ slots) {
  const sap::SweepAxes axes = frameAxes(*counters, max_slabs);
  const unsigned long long total = first_entry[n];
  if (globalThread() == 0) counters->entries = total;
  const std::uint64_t items = n > capacity ? n : capacity;
  for (std::uint64_t i = globalThread(); i < items; i += gridThreads()) {
    if (i >= total && i < capacity) keys[i] = kNoEntry;
    if (i >= n || first_entry[i] == first_entry[i + 1]) continue;
    const ObjectBounds& box = objects[i];
    const SlabRange slabs = slabsOf(axes, box);
    const std::uint64_t min_key = orderedKey(box.min[axes.sweep]);
    std::uint64_t entry = first_entry[i];
    for (std::uint32_t slab = slabs.first; slab <= slabs.last && entry < capacity;
         ++slab, ++entry) {
      keys[entry] = (std::uint64_t{slab} << 32) | min_key;
      slots[entry] = static_cast<std::uint32_t>(i);
    }
  }
}

// counts[r] = the candidates of the entry at rank r; counts[entries] = 0, so
// that the exclusive scan of entries + 1 counts ends in the total.
__global__ void __launch_bounds__(kThreadsPerBlock)
    candidateCountKernel(const ObjectBounds* __restrict__ objects, std::uint64_t entries,
                         const FrameCounters* __restrict__ counters,
                         const std::uint64_t* __restrict__ sorted_keys,
                         const std::uint32_t* __restrict__ sorted_slots,
                         unsigned long long* __restrict__ counts) {
  const sap::SweepAxes axes = frameAxes(*counters, 1);  // the sweep axis only
  for (std::uint64_t rank = globalThread(); rank <= entries; rank += gridThreads()) {
    unsigned long long count = 0;
    if (rank < entries && sorted_keys[rank] != kNoEntry) {
      const std::uint64_t slab = sorted_keys[rank] >> 32;
      const std::uint64_t end_key =
          (slab << 32) | orderedKey(objects[sorted_slots[rank]].max[axes.sweep]);
      const std::uint64_t end = upperBound(sorted_keys, rank + 1, entries, end_key);
      count = end - rank - 1;
    }
    counts[rank] = count;
  }
}

// Tests every candidate (owner rank r, candidate rank j) and appends the
// pairs' keys, one atomic per warp step.  Pairs past `capacity` are counted,
// not stored.
__global__ void __launch_bounds__(kThreadsPerBlock)
    sweepKernel(const ObjectBounds* __restrict__ objects, std::uint64_t entries,
                std::uint32_t max_slabs, const std::uint64_t* __restrict__ sorted_keys,
                const std::uint32_t* __restrict__ sorted_slots,
                const unsigned long long* __restrict__ offsets,
                FrameCounters* __restrict__ counters, std::uint64_t* __restrict__ pairs,
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
      if (found && slot < capacity) {
        // pairKey()'s form (lower slot high), which device code cannot call.
        pairs[slot] = a < b ? (std::uint64_t{a} << 32) | b : (std::uint64_t{b} << 32) | a;
      }
    }
  }
}

// Whether the frame outgrew the host's capacities: then its pairs are not all there.
__host__ __device__ inline bool spoiled(std::uint64_t entries, std::uint64_t pairs,
                                        std::uint64_t entry_capacity, std::uint64_t pair_capacity) {
  return entries > entry_capacity || pairs > pair_capacity;
}

// The selection rule of the frame's changes: a real key not in a sorted set
// (whose tail may be kNoPair), and nothing at all in a spoiled frame.
struct NotIn {
  const std::uint64_t* set;
  std::uint64_t count;
  const FrameCounters* counters;
  std::uint64_t entry_capacity;
  std::uint64_t pair_capacity;
  __host__ __device__ bool operator()(std::uint64_t key) const {
    if (key == kNoPair ||
        spoiled(counters->entries, counters->pairs, entry_capacity, pair_capacity))
      return false;
    const std::uint64_t after = upperBound(set, 0, count, key);
    return after == 0 || set[after - 1] != key;
  }
};

// Rewrites the selected keys of `added` and `removed` in place as IndexPairs
// (the same 8 bytes), the form the host hands out, and fills the result
// block: the counts and the lists' heads.
__global__ void __launch_bounds__(kThreadsPerBlock)
    packKernel(std::uint64_t* __restrict__ added, std::uint64_t* __restrict__ removed,
               const FrameCounters* __restrict__ counters, ResultBlock* __restrict__ block) {
  const unsigned long long added_count = counters->added;
  const unsigned long long removed_count = counters->removed;
  if (globalThread() == 0) {
    block->entries = counters->entries;
    block->pairs = counters->pairs;
    block->added = added_count;
    block->removed = removed_count;
  }
  for (int list = 0; list < 2; ++list) {
    std::uint64_t* const keys = list == 0 ? added : removed;
    const unsigned long long count = list == 0 ? added_count : removed_count;
    const unsigned long long head_start = list == 0 ? 0 : added_count;
    for (std::uint64_t i = globalThread(); i < count; i += gridThreads()) {
      const std::uint64_t key = keys[i];
      const IndexPair pair{static_cast<std::uint32_t>(key >> 32), static_cast<std::uint32_t>(key)};
      ::memcpy(&keys[i], &pair, sizeof pair);
      if (head_start + i < kHeadEntries) block->head[head_start + i] = pair;
    }
  }
}

}  // namespace overlap::finders::sap_kernels
