// cpusap: an exact, parallel, SIMD sort-and-sweep pair finder on the CPU,
// the fastest exact finder where there is no GPU.
//
// Each frame, inside launch():
//   1. sort out the boxes: unused slots (group or mask 0) and boxes with a
//      NaN pair with nothing and are dropped; an inverted box (min > max on
//      some axis, no NaN) cannot be swept and is brute-forced in step 6;
//   2. choose the axes: sweep along the one whose box centres spread most
//      (variance; kept unless another spreads clearly more), cut the next
//      widest into slabs a few mean box extents wide;
//   3. sort the boxes by their min on the sweep axis: insertion sort on last
//      frame's order while the boxes move little, else a radix sort on the
//      float bits;
//   4. lay them out slab by slab, structure-of-arrays (gpu/pairs/sap_sweep.h);
//   5. sweep: each box against the boxes of its slab that start inside its
//      extent, eight at a time with AVX2; the layout is cut into chunks of
//      about equal work (the boxes' extents on the sweep axis) that the task system
//      hands to the threads as they come free;
//   6. test the inverted boxes against every box, one by one;
//   7. group the pairs by lower slot (gpu/pairs/pair_set.h) and merge them with
//      last frame's: the delta, sorted, with no help from Bullet.
// finish() only hands the delta over.  Past the pair limit the sweep's lists
// stop growing (gpu/pairs/pair_set.h's KeyLimit) and step 7 is skipped;
// finish() refuses the frame.
//
// A frame in which few boxes changed skips all of that: the moved-box path
// (gpu/cpu/cpu_sap_moved_boxes.h, owned by the finder) queries only the boxes
// that changed against this search's last layout.  The full search runs
// again when that path declines: too many boxes changed since, or a box is
// inverted.
//
// Invariants: the same inclusive test and filters as gpu/pairs/pair_logic.h, so
// every frame's pairs are exactly cpubf's (its brute-force twin, kept as the
// reference); the axes, the kernel and the thread count change the speed,
// never the answer.  A launch() that throws keeps last frame's pairs.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "gpu/cpu/cpu_sap_moved_boxes.h"
#include "gpu/pair_finder.h"
#include "gpu/pairs/pair_set.h"
#include "gpu/pairs/sap_sweep.h"
#include "gpu/task_system.h"

namespace overlap::finders {

class CpuSweepAndPruneFinder final : public PairFinder {
 public:
  // Searches on `tasks`' threads.  Throws std::runtime_error for kAvx2 on a
  // CPU without AVX2.
  explicit CpuSweepAndPruneFinder(TaskSystem& tasks = defaultTaskSystem(),
                                  sap::SweepKernel kernel = sap::SweepKernel::kFastest);

  std::string_view name() const override { return "cpusap"; }

  // kScalar or kAvx2: the kernel that sweeps.
  sap::SweepKernel kernel() const { return kernel_; }
  // The last search's sweep axis (0 x, 1 y, 2 z) and slabs.
  int sweepAxis() const { return sweep_axis_; }
  const sap::SlabGrid& slabs() const { return grid_; }
  // Whether the last search sorted by insertion on the frame before's order.
  bool lastSortWasIncremental() const { return sorted_incrementally_; }
  // Whether the last search queried only the moved boxes.
  bool lastSearchWasMovedOnly() const { return moved_only_; }

 private:
  // changed: the caller's changed slots, or null to compare every box.
  void startSearch(std::span<const ObjectBounds> objects,
                   const std::span<const std::uint32_t>* changed) override;
  PairDelta finishSearch() override;
  SearchStats searchStats() const override { return stats_; }

  // What step 1 measures of the swept boxes, per axis.
  struct Spread {
    std::array<double, 3> variance{};          // of the centres
    std::array<double, 3> mean_extent{};       // of the finite extents
    std::array<float, 3> lowest{}, highest{};  // finite coordinates only
  };

  // Step 1: fills regular_ and inverted_.
  Spread sortOutBoxes(std::span<const ObjectBounds> objects);
  // Step 2: sets sweep_axis_, slab_axis_ and grid_.
  void chooseAxes(const Spread& spread);
  // Step 3: entries_ sorted by the boxes' min on sweep_axis_.
  void sortBoxes(std::span<const ObjectBounds> objects, bool same_axis);
  bool insertionSortWithin(std::size_t moves);
  void radixSort();
  // Steps 4 to 7.
  void layOut(std::span<const ObjectBounds> objects);
  void sweep();
  void testInvertedBoxes(std::span<const ObjectBounds> objects);
  void computeDelta();
  // Steps 1 to 7, after which the moved-box path queries this frame's layout.
  void searchAll(std::span<const ObjectBounds> objects);

  TaskSystem& tasks_;
  sap::SweepKernel kernel_;
  std::vector<PairKeys> thread_pairs_;  // one a thread of tasks_, by threadIndex()
  PairKeys inverted_pairs_;
  KeyLimit key_limit_;       // both count into it: pairLimit() for the sweep's lists
  bool over_limit_ = false;  // this frame has more pairs than pairLimit()

  std::uint32_t slot_count_ = 0;
  int sweep_axis_ = -1;  // none yet
  int slab_axis_ = -1;
  sap::SlabGrid grid_;
  bool sorted_incrementally_ = false;
  std::vector<std::uint32_t> regular_;   // the slots the sweep takes, ascending
  std::vector<std::uint32_t> inverted_;  // the slots step 6 takes
  std::vector<std::uint8_t> placed_;     // per slot: 1 swept, 2 placed by step 3
  // Sorted boxes as (order-preserving bits of the sweep-axis min) << 32 | slot;
  // kept for the next frame's insertion sort.
  std::vector<std::uint64_t> entries_;
  std::vector<std::uint64_t> radix_scratch_;
  std::array<std::vector<std::uint32_t>, 3> radix_counts_;  // one histogram per pass

  sap::SweepLayout layout_;
  std::vector<std::uint32_t> chunk_starts_;  // chunk k is [starts[k], starts[k + 1])

  std::vector<std::span<const std::uint64_t>> batches_;  // step 7's input
  PairSet previous_, current_;
  std::vector<DeltaPart> delta_parts_;
  std::vector<IndexPair> added_, removed_;
  SearchStats stats_;  // its search_ms and phases

  bool moved_only_ = false;
  SapMovedBoxes moved_boxes_;
};

}  // namespace overlap::finders
