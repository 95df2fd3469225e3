// gpusap's kernels and device helpers (included by gpu/gpu_sap_pair_finder.cu
// only): the sweep axis, the sort keys, each box's candidate count, the
// balanced sweep, and the pair-set helpers the CUB selections use.
//
// Rules the kernels share, each with its reason:
// - A box is swept only if it can pair: no NaN coordinate (NaN compares false
//   on every test) and group != 0 and mask != 0 (a zero filter accepts
//   nothing: unused slots).  The others get the largest key, kUnswept, which
//   no swept box's max reaches (an ordered +inf is below it), so they sort
//   last and fall in no candidate range.
// - Keys are the ordered bits of min on the sweep axis with -0 read as +0:
//   -0 == +0 as floats, and a key order that split them would miss a box
//   starting at +0 against one ending at -0.
// - Sorted by key, box r pairs only with boxes after it whose key is at most
//   the key of r's max: ranks r + 1 .. upper_bound(max) - 1, its candidates.
//   The other half of the axis test holds by the order; every candidate gets
//   pair_logic's full test, so the pairs are exactly the brute force's.
// - Candidate t (0 .. total) belongs to the rank r with offset[r] <= t <
//   offset[r + 1] (an exclusive scan of the counts): the sweep hands out
//   candidates, not boxes, so one long box spreads over many warps instead
//   of serialising one thread.
#pragma once

#include <cuda_runtime.h>
#include <string.h>  // ::memcpy, which device code may call too

#include <cstdint>
#include <type_traits>

#include "gpu/pair_logic.h"

namespace overlap::gpu::sap_kernels {

inline constexpr unsigned kThreadsPerBlock = 256;
inline constexpr unsigned kFullWarp = 0xFFFFFFFFu;
inline constexpr unsigned kLanes = 32;
// Each warp takes this many candidates at a time, 32 consecutive per step.
inline constexpr unsigned kStepsPerWarp = 8;
inline constexpr std::uint64_t kWarpSpan = kLanes * kStepsPerWarp;
inline constexpr std::uint32_t kUnswept = 0xFFFFFFFFu;

// Per frame, on the device: what the kernels count.  centre_bounds holds,
// for each axis, the ordered bits of the least centre and the complement of
// those of the greatest, so that one 0xFF fill starts both and atomicMin
// lowers both.
struct FrameCounters {
  std::uint32_t centre_bounds[3][2];
  unsigned long long pairs;  // found by the sweep; may exceed the pair capacity
  unsigned long long added;
  unsigned long long removed;
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

// The axis along which the swept boxes' centres spread widest (x if none).
__host__ __device__ inline int sweepAxis(const FrameCounters& counters) {
  int best = 0;
  float best_spread = -1.0f;
  for (int axis = 0; axis < 3; ++axis) {
    const float low = fromOrderedKey(counters.centre_bounds[axis][0]);
    const float high = fromOrderedKey(~counters.centre_bounds[axis][1]);
    const float spread = high - low;
    if (spread > best_spread) {  // false for NaN: an axis with no finite centre
      best = axis;
      best_spread = spread;
    }
  }
  return best;
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

// The least and greatest finite centre of the swept boxes on each axis.
__global__ void __launch_bounds__(kThreadsPerBlock)
    centreBoundsKernel(const ObjectBounds* __restrict__ objects, std::uint32_t n,
                       FrameCounters* __restrict__ counters) {
  std::uint32_t low[3] = {kUnswept, kUnswept, kUnswept};
  std::uint32_t high_complement[3] = {kUnswept, kUnswept, kUnswept};
  for (std::uint64_t i = globalThread(); i < n; i += gridThreads()) {
    const ObjectBounds box = objects[i];
    if (!swept(box)) continue;
    for (int axis = 0; axis < 3; ++axis) {
      const float centre = 0.5f * box.min[axis] + 0.5f * box.max[axis];
      if (!(centre - centre == 0.0f)) continue;  // infinite (or NaN from -inf + inf)
      const std::uint32_t key = orderedKey(centre);
      low[axis] = low[axis] < key ? low[axis] : key;
      high_complement[axis] = high_complement[axis] < ~key ? high_complement[axis] : ~key;
    }
  }
  // Every lane of the (full) warp gets here: reduce across it, then one atomic each.
  for (int axis = 0; axis < 3; ++axis) {
    for (int offset = 16; offset > 0; offset /= 2) {
      const std::uint32_t other_low = __shfl_xor_sync(kFullWarp, low[axis], offset);
      const std::uint32_t other_high = __shfl_xor_sync(kFullWarp, high_complement[axis], offset);
      low[axis] = low[axis] < other_low ? low[axis] : other_low;
      high_complement[axis] =
          high_complement[axis] < other_high ? high_complement[axis] : other_high;
    }
    if (threadIdx.x % kLanes == 0) {
      atomicMin(&counters->centre_bounds[axis][0], low[axis]);
      atomicMin(&counters->centre_bounds[axis][1], high_complement[axis]);
    }
  }
}

__global__ void __launch_bounds__(kThreadsPerBlock)
    sortKeysKernel(const ObjectBounds* __restrict__ objects, std::uint32_t n,
                   const FrameCounters* __restrict__ counters, std::uint32_t* __restrict__ keys,
                   std::uint32_t* __restrict__ slots) {
  const int axis = sweepAxis(*counters);
  for (std::uint64_t i = globalThread(); i < n; i += gridThreads()) {
    const ObjectBounds& box = objects[i];
    keys[i] = swept(box) ? orderedKey(box.min[axis]) : kUnswept;
    slots[i] = static_cast<std::uint32_t>(i);
  }
}

// counts[r] = the candidates of the box at rank r; counts[n] = 0, so that
// the exclusive scan of n + 1 counts ends in the total.
__global__ void __launch_bounds__(kThreadsPerBlock)
    candidateCountKernel(const ObjectBounds* __restrict__ objects, std::uint32_t n,
                         const FrameCounters* __restrict__ counters,
                         const std::uint32_t* __restrict__ sorted_keys,
                         const std::uint32_t* __restrict__ sorted_slots,
                         unsigned long long* __restrict__ counts) {
  const int axis = sweepAxis(*counters);
  for (std::uint64_t rank = globalThread(); rank <= n; rank += gridThreads()) {
    unsigned long long count = 0;
    if (rank < n && sorted_keys[rank] != kUnswept) {
      const std::uint32_t end_key = orderedKey(objects[sorted_slots[rank]].max[axis]);
      const std::uint64_t end = upperBound(sorted_keys, rank + 1, n, end_key);
      count = end - rank - 1;
    }
    counts[rank] = count;
  }
}

// Tests every candidate (owner rank r, candidate rank j) and appends the
// pairs' keys, one atomic per warp step.  Pairs past `capacity` are counted,
// not stored: the host sees the count and sweeps again into more room.
__global__ void __launch_bounds__(kThreadsPerBlock)
    sweepKernel(const ObjectBounds* __restrict__ objects, std::uint32_t n,
                const std::uint32_t* __restrict__ sorted_slots,
                const unsigned long long* __restrict__ offsets,
                FrameCounters* __restrict__ counters, std::uint64_t* __restrict__ pairs,
                unsigned long long capacity) {
  const unsigned long long total = offsets[n];
  const unsigned lane = threadIdx.x % kLanes;
  const std::uint64_t first_warp = globalThread() / kLanes;
  const std::uint64_t warps = gridThreads() / kLanes;
  for (std::uint64_t base = first_warp * kWarpSpan; base < total; base += warps * kWarpSpan) {
    // This lane's owner for its first candidate; later ones only move it forward.
    std::uint64_t owner = upperBound(offsets, 0, std::uint64_t{n} + 1, base + lane) - 1;
    for (unsigned step = 0; step < kStepsPerWarp; ++step) {  // uniform across the warp
      const std::uint64_t t = base + step * kLanes + lane;
      bool found = false;
      std::uint32_t a = 0;
      std::uint32_t b = 0;
      if (t < total) {
        if (offsets[owner + 1] <= t)
          owner = upperBound(offsets, owner + 1, std::uint64_t{n} + 1, t) - 1;
        const std::uint64_t candidate = owner + 1 + (t - offsets[owner]);
        a = sorted_slots[owner];
        b = sorted_slots[candidate];
        found = pair_logic::objectsPair(objects[a], objects[b]);
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

// Rewrites the first `*count` keys of `keys` in place as IndexPairs (the same
// 8 bytes), the form the host hands out.
__global__ void __launch_bounds__(kThreadsPerBlock)
    toIndexPairsKernel(std::uint64_t* __restrict__ added, std::uint64_t* __restrict__ removed,
                       const FrameCounters* __restrict__ counters) {
  for (int list = 0; list < 2; ++list) {
    std::uint64_t* const keys = list == 0 ? added : removed;
    const unsigned long long count = list == 0 ? counters->added : counters->removed;
    for (std::uint64_t i = globalThread(); i < count; i += gridThreads()) {
      const std::uint64_t key = keys[i];
      const IndexPair pair{static_cast<std::uint32_t>(key >> 32), static_cast<std::uint32_t>(key)};
      ::memcpy(&keys[i], &pair, sizeof pair);
    }
  }
}

// The selection rule of the frame's changes: a key not in a sorted set.
struct NotIn {
  const std::uint64_t* set;
  std::uint64_t count;
  __host__ __device__ bool operator()(std::uint64_t key) const {
    const std::uint64_t after = upperBound(set, 0, count, key);
    return after == 0 || set[after - 1] != key;
  }
};

}  // namespace overlap::gpu::sap_kernels
