#include "gpu/cpu/cpu_sweep_and_prune.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "gpu/pairs/pair_logic.h"

namespace overlap::finders {
namespace {

// Step 2: another axis takes over only when its centres' variance exceeds
// the current axis' by this factor, so that two axes of about the same
// spread do not trade places (and force a full sort) every frame.
constexpr double kAxisSwitchFactor = 1.1;
// Boxes sampled to measure the spread.
constexpr std::size_t kSpreadSamples = 2048;

// Step 3: the insertion sort gives up, for the radix sort, after this many
// moves per box; a radix sort costs about as much as that.
constexpr std::size_t kInsertionMovesPerBox = 6;
constexpr int kRadixPasses = 3;
constexpr int kRadixBits[kRadixPasses] = {11, 11, 10};  // the 32 key bits, low first

// Step 5: chunks per thread, so that a thread that drew dense chunks is
// relieved by the others; and entries per chunk at least, so that a chunk's
// task costs much more than handing it out.
constexpr std::size_t kChunksPerThread = 8;
constexpr std::size_t kMinEntriesPerChunk = 512;
// Steps 4 and 7 go parallel in pieces of at least this many entries or slots.
constexpr std::size_t kMinEntriesPerGather = 2048;
constexpr std::size_t kMinSlotsPerDeltaPart = 1024;
// Step 7 counts the threads' pair batches in parallel when each holds this many.
constexpr std::size_t kMinPairsPerParallelBatch = 8192;

sap::SweepKernel resolveKernel(sap::SweepKernel kernel) {
  if (kernel == sap::SweepKernel::kFastest) {
    return sap::avx2Available() ? sap::SweepKernel::kAvx2 : sap::SweepKernel::kScalar;
  }
  if (kernel == sap::SweepKernel::kAvx2 && !sap::avx2Available()) {
    throw std::runtime_error("cpusap: the AVX2 kernel was asked for, but this CPU has no AVX2");
  }
  return kernel;
}

}  // namespace

CpuSweepAndPruneFinder::CpuSweepAndPruneFinder(TaskSystem& tasks, sap::SweepKernel kernel)
    : tasks_(tasks),
      kernel_(resolveKernel(kernel)),
      thread_pairs_(static_cast<std::size_t>(tasks.threads())),
      moved_boxes_(tasks) {
  for (PairKeys& pairs : thread_pairs_) pairs.limitBy(&key_limit_);
  inverted_pairs_.limitBy(&key_limit_);
}

CpuSweepAndPruneFinder::Spread CpuSweepAndPruneFinder::sortOutBoxes(
    std::span<const ObjectBounds> objects) {
  regular_.clear();
  inverted_.clear();
  placed_.assign(slot_count_, 0);
  for (std::uint32_t slot = 0; slot < slot_count_; ++slot) {
    switch (pair_logic::boxUse(objects[slot])) {
      case pair_logic::BoxUse::kOrdered:
        regular_.push_back(slot);
        placed_[slot] = 1;  // swept, not yet placed by step 3
        break;
      case pair_logic::BoxUse::kInverted:
        inverted_.push_back(slot);
        break;
      case pair_logic::BoxUse::kNone:
        break;
    }
  }

  // The spread only steers the axes and the slabs, never the answer: a
  // sample of the boxes measures it well enough.  Centres are summed
  // relative to the first one, in double, so that boxes far from the origin
  // keep their spread.
  Spread spread;
  spread.lowest.fill(std::numeric_limits<float>::infinity());
  spread.highest.fill(-std::numeric_limits<float>::infinity());
  std::array<double, 3> origin{}, sum{}, sum_of_squares{}, extents{};
  std::size_t sampled = 0;
  const std::size_t stride = std::max<std::size_t>(1, regular_.size() / kSpreadSamples);
  for (std::size_t k = 0; k < regular_.size(); k += stride) {
    const ObjectBounds& box = objects[regular_[k]];
    float all = 0;
    for (int axis = 0; axis < 3; ++axis) all += box.min[axis] + box.max[axis];
    if (!std::isfinite(all)) continue;  // an infinite box (or one near FLT_MAX)
    std::array<double, 3> centre;
    for (int axis = 0; axis < 3; ++axis) {
      centre[axis] = 0.5 * (double{box.min[axis]} + double{box.max[axis]});
      spread.lowest[axis] = std::min(spread.lowest[axis], box.min[axis]);
      spread.highest[axis] = std::max(spread.highest[axis], box.max[axis]);
    }
    if (sampled++ == 0) origin = centre;
    for (int axis = 0; axis < 3; ++axis) {
      const double offset = centre[axis] - origin[axis];
      sum[axis] += offset;
      sum_of_squares[axis] += offset * offset;
      extents[axis] += double{box.max[axis]} - double{box.min[axis]};
    }
  }
  for (int axis = 0; axis < 3 && sampled > 0; ++axis) {
    const double count = static_cast<double>(sampled);
    const double mean = sum[axis] / count;
    spread.variance[axis] = sum_of_squares[axis] / count - mean * mean;
    spread.mean_extent[axis] = extents[axis] / count;
  }
  return spread;
}

void CpuSweepAndPruneFinder::chooseAxes(const Spread& spread) {
  const std::array<double, 3>& variance = spread.variance;
  const int widest =
      static_cast<int>(std::max_element(variance.begin(), variance.end()) - variance.begin());
  if (sweep_axis_ < 0 || variance[widest] > kAxisSwitchFactor * variance[sweep_axis_]) {
    sweep_axis_ = widest;
  }
  const int next = (sweep_axis_ + 1) % 3, after = (sweep_axis_ + 2) % 3;
  slab_axis_ = variance[next] >= variance[after] ? next : after;

  // Slabs over the finite coordinates; the outer slabs also take what lies beyond.
  grid_ = sap::SlabGrid{};
  const double lowest = spread.lowest[slab_axis_];
  const double range = double{spread.highest[slab_axis_]} - lowest;
  const double width = sap::kSlabWidthInExtents * spread.mean_extent[slab_axis_];
  if (!(range > 0) || !(width > 0)) return;  // nothing finite, or all flat
  const double most =
      std::max<double>(1, static_cast<double>(regular_.size() / sap::kMinBoxesPerSlab));
  const double slabs = std::min(std::ceil(range / width), most);
  if (slabs < 2) return;
  grid_.count = static_cast<std::uint32_t>(slabs);
  grid_.origin = static_cast<float>(lowest);
  grid_.inverse_width = static_cast<float>(slabs / range);
}

void CpuSweepAndPruneFinder::sortBoxes(std::span<const ObjectBounds> objects, bool same_axis) {
  sorted_incrementally_ = false;
  if (same_axis && !entries_.empty()) {
    // Last frame's order, re-keyed, without the boxes that left the sweep,
    // then the boxes that joined it.
    std::size_t kept = 0;
    for (const std::uint64_t entry : entries_) {
      const auto slot = static_cast<std::uint32_t>(entry);
      if (slot < slot_count_ && placed_[slot] == 1) {
        entries_[kept++] = sap::sortEntry(objects[slot], sweep_axis_, slot);
        placed_[slot] = 2;  // 2: placed
      }
    }
    entries_.resize(kept);
    for (std::size_t k = 0; kept < regular_.size() && k < regular_.size(); ++k) {
      const std::uint32_t slot = regular_[k];
      if (placed_[slot] == 1) {
        entries_.push_back(sap::sortEntry(objects[slot], sweep_axis_, slot));
        ++kept;
      }
    }
    sorted_incrementally_ = insertionSortWithin(kInsertionMovesPerBox * entries_.size());
    if (!sorted_incrementally_) radixSort();
    return;
  }
  entries_.clear();
  for (const std::uint32_t slot : regular_)
    entries_.push_back(sap::sortEntry(objects[slot], sweep_axis_, slot));
  radixSort();
}

bool CpuSweepAndPruneFinder::insertionSortWithin(std::size_t moves) {
  std::uint64_t* const entries = entries_.data();
  const std::size_t count = entries_.size();
  for (std::size_t i = 1; i < count; ++i) {
    const std::uint64_t entry = entries[i];
    std::size_t j = i;
    for (; j > 0 && entries[j - 1] > entry; --j) entries[j] = entries[j - 1];
    entries[j] = entry;
    const std::size_t moved = i - j;
    if (moved > moves) return false;  // entries_ is still a permutation: radix sort it
    moves -= moved;
  }
  return true;
}

void CpuSweepAndPruneFinder::radixSort() {
  // Least significant digit first over the key's 32 bits (the entry's high
  // half); each pass is stable, so the order ends up by the whole key.
  const std::size_t count = entries_.size();
  static_assert(kRadixPasses == std::tuple_size_v<decltype(radix_counts_)>);
  auto& counts = radix_counts_;
  int shift = 32;
  std::array<int, kRadixPasses> shifts{};
  for (int pass = 0; pass < kRadixPasses; ++pass) {
    counts[pass].assign(std::size_t{1} << kRadixBits[pass], 0);
    shifts[pass] = shift;
    shift += kRadixBits[pass];
  }
  for (const std::uint64_t entry : entries_) {
    for (int pass = 0; pass < kRadixPasses; ++pass) {
      ++counts[pass][(entry >> shifts[pass]) & ((1u << kRadixBits[pass]) - 1)];
    }
  }
  radix_scratch_.resize(count);
  for (int pass = 0; pass < kRadixPasses; ++pass) {
    std::vector<std::uint32_t>& digit_counts = counts[pass];
    // A digit that all keys share leaves the order as it is.
    if (std::find(digit_counts.begin(), digit_counts.end(), count) != digit_counts.end()) continue;
    std::uint32_t start = 0;
    for (std::uint32_t& digit_count : digit_counts) start += std::exchange(digit_count, start);
    const std::uint64_t digit_mask = (1u << kRadixBits[pass]) - 1;
    for (const std::uint64_t entry : entries_) {
      radix_scratch_[digit_counts[(entry >> shifts[pass]) & digit_mask]++] = entry;
    }
    entries_.swap(radix_scratch_);
  }
}

void CpuSweepAndPruneFinder::layOut(std::span<const ObjectBounds> objects) {
  layout_.plan(objects, entries_, sweep_axis_, slab_axis_, grid_);
  const std::size_t grain =
      grainFor(layout_.size(), tasks_.threads(), kChunksPerThread, kMinEntriesPerGather);
  tasks_.forEachPiece(layout_.size(), grain, [&](std::size_t first, std::size_t end) {
    layout_.gather(static_cast<std::uint32_t>(first), static_cast<std::uint32_t>(end));
  });
}

void CpuSweepAndPruneFinder::sweep() {
  for (PairKeys& pairs : thread_pairs_) pairs.clear();
  const auto threads = static_cast<std::size_t>(tasks_.threads());
  const std::size_t chunks =
      std::clamp<std::size_t>(layout_.size() / kMinEntriesPerChunk, 1, threads * kChunksPerThread);
  if (threads <= 1 || chunks == 1) {
    layout_.sweep(kernel_, 0, layout_.size(), thread_pairs_[0]);
    return;
  }
  layout_.cutChunks(chunks, chunk_starts_);
  tasks_.forEachPiece(chunk_starts_.size() - 1, 1, [&](std::size_t chunk, std::size_t /*end*/) {
    layout_.sweep(kernel_, chunk_starts_[chunk], chunk_starts_[chunk + 1],
                  thread_pairs_[static_cast<std::size_t>(tasks_.threadIndex())]);
  });
}

void CpuSweepAndPruneFinder::testInvertedBoxes(std::span<const ObjectBounds> objects) {
  inverted_pairs_.clear();
  for (std::size_t i = 0; i < inverted_.size(); ++i) {
    const ObjectBounds& box = objects[inverted_[i]];
    for (const std::uint32_t slot : regular_) {
      if (pair_logic::objectsPair(box, objects[slot])) {
        inverted_pairs_.push_back(pairKey(inverted_[i], slot));
      }
    }
    for (std::size_t j = i + 1; j < inverted_.size(); ++j) {
      if (pair_logic::objectsPair(box, objects[inverted_[j]])) {
        inverted_pairs_.push_back(pairKey(inverted_[i], inverted_[j]));
      }
    }
  }
}

void CpuSweepAndPruneFinder::startSearch(std::span<const ObjectBounds> objects,
                                         const std::span<const std::uint32_t>* changed) {
  slot_count_ = checkedSlotCount(name(), slot_count_, objects.size());
  key_limit_.found.store(0, std::memory_order_relaxed);
  key_limit_.most = pairLimit();
  over_limit_ = false;
  const SapMovedBoxes::FullFrame full{layout_, grid_, sweep_axis_, slab_axis_};
  moved_only_ = moved_boxes_.search(objects, changed, full, added_, removed_, stats_.phases);
  if (!moved_only_) searchAll(objects);
  // This frame's pairs are no fewer than those it added.
  over_limit_ = over_limit_ || key_limit_.exceeded() || added_.size() > pairLimit();
  stats_.search_ms = msSinceLaunch();
  moved_boxes_.searchFinished();
}

void CpuSweepAndPruneFinder::searchAll(std::span<const ObjectBounds> objects) {
  moved_boxes_.applyPendingChanges(previous_);
  const int last_sweep_axis = sweep_axis_;
  chooseAxes(sortOutBoxes(objects));                   // steps 1, 2
  sortBoxes(objects, sweep_axis_ == last_sweep_axis);  // 3
  stats_.phases.sort_ms = msSinceLaunch();
  layOut(objects);             // 4
  sweep();                     // 5
  testInvertedBoxes(objects);  // 6
  stats_.phases.sweep_ms = msSinceLaunch() - stats_.phases.sort_ms;
  std::uint64_t found = inverted_pairs_.size();
  for (const PairKeys& pairs : thread_pairs_) found += pairs.size();
  if (key_limit_.exceeded() || found > key_limit_.most) {
    over_limit_ = true;
    added_.clear();
    removed_.clear();
    return;
  }
  computeDelta();  // 7
  layout_.indexForQueries();
  moved_boxes_.keepFullFrame(objects.first(slot_count_), !inverted_.empty());
  stats_.phases.delta_ms = msSinceLaunch() - stats_.phases.sort_ms - stats_.phases.sweep_ms;
}

void CpuSweepAndPruneFinder::computeDelta() {
  // Counting the threads' batches of pairs in parallel pays when there are
  // several and each is large.
  batches_.clear();
  std::size_t smallest_batch = std::numeric_limits<std::size_t>::max();
  for (const PairKeys& pairs : thread_pairs_) {
    if (pairs.size() == 0) continue;  // a thread that swept nothing
    batches_.push_back(pairs.keys());
    smallest_batch = std::min(smallest_batch, pairs.size());
  }
  const bool parallel = batches_.size() > 1 && smallest_batch >= kMinPairsPerParallelBatch;
  batches_.push_back(inverted_pairs_.keys());
  if (parallel) {
    const PairSet::ForEachPart on_tasks = [this](std::size_t parts,
                                                 const std::function<void(std::size_t)>& part) {
      tasks_.forEachPiece(parts, 1, [&](std::size_t k, std::size_t /*end*/) { part(k); });
    };
    current_.assign(slot_count_, batches_, &on_tasks);
  } else {
    current_.assign(slot_count_, batches_);
  }
  // Rows in parts, compared in parallel, then joined in order.
  const auto threads = static_cast<std::size_t>(tasks_.threads());
  const std::size_t parts =
      std::clamp<std::size_t>(slot_count_ / kMinSlotsPerDeltaPart, 1, threads * kChunksPerThread);
  delta_parts_.resize(std::max(delta_parts_.size(), parts));
  const auto bound = [&](std::size_t part) {
    return static_cast<std::uint32_t>(std::uint64_t{slot_count_} * part / parts);
  };
  tasks_.forEachPiece(parts, 1, [&](std::size_t first, std::size_t end) {
    for (std::size_t part = first; part < end; ++part) {
      delta_parts_[part].added.clear();
      delta_parts_[part].removed.clear();
      appendDelta(previous_, current_, bound(part), bound(part + 1), delta_parts_[part]);
    }
  });
  added_.clear();
  removed_.clear();
  for (std::size_t part = 0; part < parts; ++part) {
    added_.insert(added_.end(), delta_parts_[part].added.begin(), delta_parts_[part].added.end());
    removed_.insert(removed_.end(), delta_parts_[part].removed.begin(),
                    delta_parts_[part].removed.end());
  }
  std::swap(previous_, current_);
}

PairDelta CpuSweepAndPruneFinder::finishSearch() {
  if (over_limit_) throw pairLimitError();
  return PairDelta{added_, removed_};
}

}  // namespace overlap::finders
