// The sweep of cpusap (gpu/cpu/cpu_sap_pair_finder.h): boxes sorted by their
// minimum on the sweep axis, each tested against the boxes that start inside
// its own extent on that axis, within slabs of a second axis.
//
// Sorted by the sweep axis' min s, box i can pair only with a box j > i that
// starts before i ends (s_min[j] <= s_max[i]; the other half of the test,
// s_min[i] <= s_max[j], holds by the order).  Those boxes are the run right
// after i, and the first one past s_max[i] ends i's scan.  Each candidate is
// then tested on the other two axes and on the collision filters, with the
// inclusive comparisons of gpu/pairs/pair_logic.h, so the pairs are exactly the
// brute force's.  A scan ends at its own box's max: scene 4's large boxes
// lengthen their own scans and no one else's.
//
// A scan along one axis still meets every box in a slice across the whole
// scene.  So the second axis (the slab axis) is cut into slabs a few mean
// box extents wide; each slab holds, in sweep order, the boxes that reach
// into it, and scans stay inside their slab.  Two boxes that overlap on the
// slab axis share a slab (slabOf() is monotone), and a pair is reported only
// in the first slab they share, the one where one of them starts, so no pair
// is found twice.  On the scene-4 streams' frame 40 this cut the candidates
// per box six- to eight-fold (96 to 17 at n = 3500, 199 to 25 at 10000).
//
// Two kernels give the same pairs: a scalar one, and one built for AVX2 that
// tests eight candidates per step; which runs is chosen at run time.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <span>
#include <vector>

#include "gpu/pairs/pair_logic.h"
#include "gpu/pairs/pair_set.h"
#include "gpu/pairs/pair_types.h"

namespace overlap::finders::sap {

inline constexpr std::uint32_t kLanes = 8;

enum class SweepKernel {
  kFastest,  // AVX2 where the CPU has it, else scalar
  kScalar,
  kAvx2,
};

// True when this CPU (and this build) can run the AVX2 kernel.
bool avx2Available();

// The float's bits as an unsigned key with the same order: -inf < ... < -0 <
// +0 < ... < +inf.  Not for NaN, which cpusap keeps out of its sorts.
inline std::uint32_t orderedBits(float value) {
  const auto bits = std::bit_cast<std::uint32_t>(value);
  return bits ^ ((bits >> 31) != 0 ? 0xFFFFFFFFu : 0x80000000u);
}

// What cpusap sorts: the key of the box's min on `axis`, then the slot.
inline std::uint64_t sortEntry(const ObjectBounds& box, int axis, std::uint32_t slot) {
  return (std::uint64_t{orderedBits(box.min[axis])} << 32) | slot;
}

// Slabs this many mean box extents wide: on scene-4 streams, 3 to 4 gave
// cpusap the fewest sweep steps (wider slabs hold more boxes per scan,
// narrower ones copy more boxes into several slabs).
inline constexpr double kSlabWidthInExtents = 3.0;
// At least this many boxes per slab on average, so that a few boxes never
// make many nearly empty slabs.
inline constexpr std::uint32_t kMinBoxesPerSlab = 32;
// gpusap's most slabs: the slab takes bit_width(kMaxGpuSlabs - 1) bits of
// its 64-bit sort key, above the 32 of the sweep axis' min.
inline constexpr std::uint32_t kMaxGpuSlabs = 1024;

// Slabs of equal width along the slab axis, the outer ones open-ended
// (cpusap's, and gpusap's: gpu/cuda/gpu_sap_kernels.cuh).
struct SlabGrid {
  float origin = 0;  // where slab 0 starts (it also takes everything below)
  float inverse_width = 0;
  std::uint32_t count = 1;

  // Non-decreasing in v (rounding is monotone), so two intervals that overlap
  // map to slab ranges that overlap.  Not for NaN.  Host and device (gpusap).
  OVERLAP_HD std::uint32_t slabOf(float v) const {
    if (count == 1) return 0;
    const float t = (v - origin) * inverse_width;
    const float last = static_cast<float>(count - 1);
    return static_cast<std::uint32_t>(t < 0.0f ? 0.0f : (t > last ? last : t));
  }
};

// gpusap's axes and slabs for a frame (gpu/cuda/gpu_sap_kernels.cuh; cpusap
// chooses its own, from a sample and with hysteresis): sweep along the axis
// whose centres spread widest (x if none is finite), cut the wider of the
// other two into slabs kSlabWidthInExtents mean box extents wide, at most
// max_slabs.  lowest and highest: the least and greatest finite centre per
// axis (NaN where none); extent_sum over the `finite` boxes with every
// coordinate finite.  Host and device.
struct SweepAxes {
  int sweep = 0;
  int slab = 1;
  SlabGrid grid;
};

OVERLAP_HD inline SweepAxes chooseSweepAxes(const float (&lowest)[3], const float (&highest)[3],
                                            const double (&extent_sum)[3], std::uint64_t finite,
                                            std::uint32_t max_slabs) {
  SweepAxes axes;
  float spread[3];
  for (int axis = 0; axis < 3; ++axis) spread[axis] = highest[axis] - lowest[axis];
  float best_spread = -1.0f;
  for (int axis = 0; axis < 3; ++axis) {
    if (spread[axis] > best_spread) {  // false for NaN
      axes.sweep = axis;
      best_spread = spread[axis];
    }
  }
  const int next = (axes.sweep + 1) % 3;
  const int after = (axes.sweep + 2) % 3;
  axes.slab = spread[after] > spread[next] ? after : next;
  if (finite == 0) return axes;
  const double range = spread[axes.slab];
  const double width = kSlabWidthInExtents * extent_sum[axes.slab] / static_cast<double>(finite);
  if (!(range > 0) || !(width > 0)) return axes;  // nothing finite, or all flat
  const double wanted = range / width;
  // ceil(wanted), capped, in steps that cannot overflow.
  const double slabs = wanted >= max_slabs
                           ? static_cast<double>(max_slabs)
                           : static_cast<double>(static_cast<std::uint32_t>(wanted) + 1);
  if (slabs < 2) return axes;
  axes.grid.count = static_cast<std::uint32_t>(slabs);
  axes.grid.origin = lowest[axes.slab];
  axes.grid.inverse_width = static_cast<float>(slabs / range);
  return axes;
}

// The boxes laid out for the sweep: slab after slab, each slab's boxes in
// sweep order, structure-of-arrays, each slab followed by kLanes entries
// whose sweep_min is NaN, so that every scan stops at its slab's end without
// a bounds check.
class SweepLayout {
 public:
  // Plans the layout of the boxes in `sorted` (slot in the low 32 bits),
  // sorted by their min on `sweep_axis`, each with min <= max on every axis:
  // which entry holds which box.  `objects` must outlive gather().
  void plan(std::span<const ObjectBounds> objects, std::span<const std::uint64_t> sorted,
            int sweep_axis, int slab_axis, const SlabGrid& grid);
  // Copies the planned boxes into entries [first, end); ranges that do not
  // overlap may be gathered at the same time.
  void gather(std::uint32_t first, std::uint32_t end);

  // Entries, padding included; a scan may start at any of them.
  std::uint32_t size() const { return static_cast<std::uint32_t>(slot_.size()); }

  // Cuts [0, size()) into `chunks` ranges of about equal work, a scan's work
  // taken as its box's extent on the sweep axis plus a fixed share; starts
  // gets chunks + 1 bounds (fewer when there are fewer entries).
  void cutChunks(std::size_t chunks, std::vector<std::uint32_t>& starts) const;

  // Scans the entries [first, end) and appends each pair found, as a
  // pairKey() of the boxes' slots, to `pairs`.  `kernel` must be kScalar or
  // kAvx2 (the latter only where avx2Available()).
  void sweep(SweepKernel kernel, std::uint32_t first, std::uint32_t end, PairKeys& pairs) const;

  // Queries of single boxes (cpusap's moved boxes), after gather():
  // indexForQueries() notes, per entry, the furthest its slab's boxes up to
  // it reach on the sweep axis (non-decreasing, so a binary search finds
  // where a query's scan begins);
  // query() then appends to `hits` the slot of every laid-out box that pairs
  // with `box` (pair_logic's test on the laid-out bounds), each once.  `box`
  // must have min <= max and no NaN; `grid` is the one plan() was given.
  void indexForQueries();
  void query(const ObjectBounds& box, const SlabGrid& grid, std::vector<std::uint32_t>& hits) const;

 private:
  std::vector<float> sweep_min_, sweep_max_;
  std::vector<float> other_min_[2], other_max_[2];  // [0]: the slab axis
  std::vector<std::int32_t> group_, mask_;
  // -1 where the entry's box starts in this slab (its first), else 0: a
  // pair is reported in a slab where one of its boxes starts.
  std::vector<std::int32_t> starts_here_;
  std::vector<std::uint32_t> slot_;  // kPaddingSlot for padding
  static constexpr std::uint32_t kPaddingSlot = 0xFFFFFFFFu;
  std::span<const ObjectBounds> objects_;
  std::array<int, 3> axes_{};               // sweep, slab, third
  std::vector<std::uint32_t> slab_starts_;  // slab s is [starts[s], starts[s + 1] - kLanes)
  std::vector<float> reach_;                // per entry: indexForQueries()
  std::vector<std::uint32_t> slab_cursor_;  // scratch
  std::vector<std::uint32_t> first_slab_, last_slab_;  // scratch, per sorted box
};

}  // namespace overlap::finders::sap
