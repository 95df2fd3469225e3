// What gpusap's sweep tests per box on a .aabbs stream's frame, counted on
// the CPU with gpusap's own rules (gpu/cuda/gpu_sweep_and_prune_kernels.cuh,
// gpu/pairs/sap_sweep.h): its candidates along one axis (the sweep before slabs) and within the
// slabs of a second axis, the entries per box the slabs cost, and the pairs
// per box (found within the slabs, each once).
// Usage: overlap_sap_candidates FILE [FRAME] (FRAME 1 unless given).
// Figures: docs/results/gpusap_candidates.md.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <limits>
#include <string>
#include <vector>

#include "gpu/base/standard_streams.h"
#include "gpu/pairs/pair_logic.h"
#include "gpu/pairs/sap_sweep.h"
#include "physics/aabb_stream.h"

namespace {

using overlap::finders::ObjectBounds;
namespace sap = overlap::finders::sap;

struct Count {
  sap::SweepAxes axes;
  std::uint64_t entries = 0;
  std::uint64_t candidates = 0;
  std::uint64_t pairs = 0;  // counted only when asked
};

Count countFrame(const std::vector<ObjectBounds>& boxes, std::uint32_t max_slabs, bool pairs) {
  float lowest[3], highest[3];
  double extent_sum[3] = {0, 0, 0};
  std::fill(lowest, lowest + 3, std::numeric_limits<float>::quiet_NaN());
  std::fill(highest, highest + 3, std::numeric_limits<float>::quiet_NaN());
  for (const ObjectBounds& box : boxes) {  // the reader's boxes are finite, min <= max
    for (int axis = 0; axis < 3; ++axis) {
      const float centre = 0.5f * box.min[axis] + 0.5f * box.max[axis];
      lowest[axis] = !(lowest[axis] <= centre) ? centre : lowest[axis];
      highest[axis] = !(highest[axis] >= centre) ? centre : highest[axis];
      extent_sum[axis] += double{box.max[axis]} - box.min[axis];
    }
  }
  Count count;
  count.axes = sap::chooseSweepAxes(lowest, highest, extent_sum, boxes.size(), max_slabs);
  const sap::SweepAxes& axes = count.axes;
  std::vector<std::uint64_t> keys;
  std::vector<std::uint32_t> slots;
  std::vector<std::uint64_t> order;
  for (std::uint32_t slot = 0; slot < boxes.size(); ++slot) {
    const ObjectBounds& box = boxes[slot];
    for (std::uint64_t slab = axes.grid.slabOf(box.min[axes.slab]);
         slab <= axes.grid.slabOf(box.max[axes.slab]); ++slab) {
      order.push_back(keys.size());
      keys.push_back((slab << 32) | sap::orderedKey(box.min[axes.sweep]));
      slots.push_back(slot);
    }
  }
  count.entries = keys.size();
  std::sort(order.begin(), order.end(),
            [&](std::uint64_t x, std::uint64_t y) { return keys[x] < keys[y]; });
  std::vector<std::uint64_t> sorted(order.size());
  for (std::size_t r = 0; r < order.size(); ++r) sorted[r] = keys[order[r]];
  for (std::size_t r = 0; r < order.size(); ++r) {
    const std::uint64_t slab = sorted[r] >> 32;
    const ObjectBounds& box = boxes[slots[order[r]]];
    const std::uint64_t end_key = (slab << 32) | sap::orderedKey(box.max[axes.sweep]);
    const auto end = std::upper_bound(sorted.begin() + r + 1, sorted.end(), end_key);
    count.candidates += static_cast<std::uint64_t>(end - sorted.begin()) - r - 1;
    if (!pairs) continue;
    for (auto j = sorted.begin() + r + 1; j != end; ++j) {
      const ObjectBounds& other = boxes[slots[order[j - sorted.begin()]]];
      const bool first_shared = axes.grid.slabOf(box.min[axes.slab]) == slab ||
                                axes.grid.slabOf(other.min[axes.slab]) == slab;
      count.pairs += overlap::finders::pair_logic::objectsPair(box, other) && first_shared;
    }
  }
  return count;
}

}  // namespace

int main(int argc, char** argv) {
  overlap::holdStandardStreams();  // first: before anything opens a file
  if (argc < 2 || argc > 3) {
    std::fprintf(stderr, "usage: overlap_sap_candidates FILE [FRAME]\n");
    return 2;
  }
  try {
    const overlap::physics::AabbStream stream = overlap::physics::readAabbStream(argv[1]);
    const int frame = argc == 3 ? std::stoi(argv[2]) : 1;
    if (frame < 0 || frame >= stream.stored_frames) {
      std::fprintf(stderr, "overlap_sap_candidates: %s has no frame %d\n", argv[1], frame);
      return 2;
    }
    std::vector<ObjectBounds> boxes;
    for (const auto& aabb : stream.frame(frame)) {
      boxes.push_back(ObjectBounds{
          {aabb.min[0], aabb.min[1], aabb.min[2]}, {aabb.max[0], aabb.max[1], aabb.max[2]}, 1, -1});
    }
    const auto n = static_cast<std::uint32_t>(boxes.size());
    const double per_box = 1.0 / static_cast<double>(n);
    const Count one_axis = countFrame(boxes, 1, false);
    const std::uint32_t max_slabs =
        std::clamp<std::uint32_t>(n / sap::kMinBoxesPerSlab, 1, sap::kMaxGpuSlabs);
    const Count slabs = countFrame(boxes, max_slabs, true);
    std::printf(
        "n,frame,sweep_axis,slab_axis,slabs,entries_per_box,candidates_per_box_one_axis,"
        "candidates_per_box_slabs,pairs_per_box\n");
    std::printf("%u,%d,%d,%d,%u,%.3f,%.1f,%.1f,%.3f\n", n, frame, slabs.axes.sweep, slabs.axes.slab,
                slabs.axes.grid.count, static_cast<double>(slabs.entries) * per_box,
                static_cast<double>(one_axis.candidates) * per_box,
                static_cast<double>(slabs.candidates) * per_box,
                static_cast<double>(slabs.pairs) * per_box);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "overlap_sap_candidates: %s\n", error.what());
    return 2;
  }
  return 0;
}
