#include "gpu/cpu/cpu_sap_moved_boxes.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iterator>
#include <stdexcept>
#include <string>

#include "gpu/base/stopwatch.h"
#include "gpu/pairs/pair_logic.h"

namespace overlap::finders {
namespace {

// The moved-box path runs while the boxes changed since the last full frame
// are at most this share of all: each moved box costs two queries, and the
// dirty boxes' own layouts are rebuilt every frame.
constexpr std::size_t kDirtyShareDivisor = 16;
// Moved boxes per piece of parallel queries.
constexpr std::size_t kMovedPerPiece = 256;

bool sameBounds(const ObjectBounds& a, const ObjectBounds& b) {
  return std::memcmp(&a, &b, sizeof(ObjectBounds)) == 0;
}

// Swept by the layouts: used, no NaN, min <= max (pair_logic::BoxUse::kOrdered).
bool searchable(const ObjectBounds& box) {
  return pair_logic::boxUse(box) == pair_logic::BoxUse::kOrdered;
}

// sorted := (sorted \ minus) u plus, all sorted, `plus` disjoint from `sorted`.
void replaceSorted(std::vector<std::uint64_t>& sorted, const std::vector<std::uint64_t>& minus,
                   const std::vector<std::uint64_t>& plus, std::vector<std::uint64_t>& scratch) {
  scratch.clear();
  std::set_difference(sorted.begin(), sorted.end(), minus.begin(), minus.end(),
                      std::back_inserter(scratch));
  sorted.clear();
  std::set_union(scratch.begin(), scratch.end(), plus.begin(), plus.end(),
                 std::back_inserter(sorted));
}

}  // namespace

void SapMovedBoxes::keepFullFrame(std::span<const ObjectBounds> objects, bool any_inverted) {
  kept_.assign(objects.begin(), objects.end());
  for (const std::uint32_t slot : dirty_) dirty_flag_[slot] = 0;
  dirty_flag_.resize(objects.size(), 0);
  moved_flag_.resize(objects.size(), 0);
  dirty_.clear();
  have_full_frame_ = !any_inverted;
}

bool SapMovedBoxes::noteIfMoved(std::span<const ObjectBounds> objects, std::uint32_t slot,
                                std::size_t limit) {
  if (sameBounds(objects[slot], kept_[slot])) return true;
  if (pair_logic::boxUse(objects[slot]) == pair_logic::BoxUse::kInverted) return false;
  moved_.push_back(slot);
  return dirty_flag_[slot] != 0 || dirty_.size() + moved_.size() <= limit;
}

bool SapMovedBoxes::findMovedBoxes(std::span<const ObjectBounds> objects,
                                   const std::span<const std::uint32_t>* changed) {
  moved_.clear();
  if (!have_full_frame_ || objects.size() != kept_.size()) return false;
  const auto slot_count = static_cast<std::uint32_t>(objects.size());
  const std::size_t limit = kept_.size() / kDirtyShareDivisor;
  if (changed == nullptr) {
    for (std::uint32_t slot = 0; slot < slot_count; ++slot) {
      if (!noteIfMoved(objects, slot, limit)) return false;
    }
    return true;
  }
  if (changed->size() > limit) return false;  // a full frame is cheaper
  for (const std::uint32_t slot : *changed) {
    if (slot >= slot_count) {
      throw std::runtime_error("cpusap: changed slot " + std::to_string(slot) + " is past the " +
                               std::to_string(slot_count) + " boxes");
    }
    if (!noteIfMoved(objects, slot, limit)) return false;
  }
  std::sort(moved_.begin(), moved_.end());  // a slot named twice is queried once
  moved_.erase(std::unique(moved_.begin(), moved_.end()), moved_.end());
  return true;
}

void SapMovedBoxes::layOutDirtyBoxes(std::span<const ObjectBounds> objects, const FullFrame& full,
                                     sap::SweepLayout& layout) {
  dirty_entries_.clear();
  for (const std::uint32_t slot : dirty_) {
    if (searchable(objects[slot])) {
      dirty_entries_.push_back(sap::sortEntry(objects[slot], full.sweep_axis, slot));
    }
  }
  std::sort(dirty_entries_.begin(), dirty_entries_.end());
  layout.plan(objects, dirty_entries_, full.sweep_axis, full.slab_axis, full.grid);
  layout.gather(0, layout.size());
  layout.indexForQueries();
}

void SapMovedBoxes::queryMovedBoxes(std::span<const ObjectBounds> objects, const FullFrame& full) {
  // One side's partners of `slot`: the clean boxes from the full frame's
  // layout, the dirty ones from that side's own layout; itself and the moved
  // boxes below it (which report the pair themselves) left out, sorted.
  const auto partners = [&](std::uint32_t slot, const ObjectBounds& box,
                            const sap::SweepLayout& dirty, std::vector<std::uint32_t>& hits) {
    hits.clear();
    if (!searchable(box)) return;
    full.layout.query(box, full.grid, hits);
    hits.erase(std::remove_if(hits.begin(), hits.end(),
                              [&](std::uint32_t other) { return dirty_flag_[other] != 0; }),
               hits.end());
    dirty.query(box, full.grid, hits);
    hits.erase(std::remove_if(hits.begin(), hits.end(),
                              [&](std::uint32_t other) {
                                return other == slot || (moved_flag_[other] != 0 && other < slot);
                              }),
               hits.end());
    std::sort(hits.begin(), hits.end());
  };
  for (MovedPairs& pairs : moved_pairs_) {
    pairs.added.clear();
    pairs.removed.clear();
  }
  tasks_.forEachPiece(moved_.size(), kMovedPerPiece, [&](std::size_t first, std::size_t end) {
    MovedPairs& pairs = moved_pairs_[static_cast<std::size_t>(tasks_.threadIndex())];
    for (std::size_t k = first; k < end; ++k) {
      const std::uint32_t slot = moved_[k];
      partners(slot, kept_[slot], dirty_before_, pairs.before);
      partners(slot, objects[slot], dirty_now_, pairs.now);
      std::size_t i = 0, j = 0;
      while (i < pairs.before.size() || j < pairs.now.size()) {
        if (j == pairs.now.size() || (i < pairs.before.size() && pairs.before[i] < pairs.now[j])) {
          pairs.removed.push_back(pairKey(slot, pairs.before[i++]));
        } else if (i == pairs.before.size() || pairs.now[j] < pairs.before[i]) {
          pairs.added.push_back(pairKey(slot, pairs.now[j++]));
        } else {
          ++i;
          ++j;
        }
      }
    }
  });
}

bool SapMovedBoxes::search(std::span<const ObjectBounds> objects,
                           const std::span<const std::uint32_t>* changed, const FullFrame& full,
                           std::vector<IndexPair>& added, std::vector<IndexPair>& removed,
                           SearchPhases& phases) {
  const bool changes_usable = kept_current_;
  kept_current_ = false;  // until this search has finished
  const HostStopwatch watch;
  if (!findMovedBoxes(objects, changes_usable ? changed : nullptr)) return false;
  for (const std::uint32_t slot : moved_) {
    moved_flag_[slot] = 1;
    if (dirty_flag_[slot] == 0) {
      dirty_flag_[slot] = 1;
      dirty_.push_back(slot);
    }
  }
  layOutDirtyBoxes(kept_, full, dirty_before_);
  layOutDirtyBoxes(objects, full, dirty_now_);
  phases.sort_ms = watch.ms();
  queryMovedBoxes(objects, full);
  phases.sweep_ms = watch.ms() - phases.sort_ms;
  collectDelta(added, removed);
  for (const std::uint32_t slot : moved_) {
    moved_flag_[slot] = 0;
    kept_[slot] = objects[slot];
  }
  phases.delta_ms = watch.ms() - phases.sort_ms - phases.sweep_ms;
  return true;
}

void SapMovedBoxes::collectDelta(std::vector<IndexPair>& added_pairs,
                                 std::vector<IndexPair>& removed_pairs) {
  std::vector<std::uint64_t> added, removed, scratch;
  for (const MovedPairs& pairs : moved_pairs_) {
    added.insert(added.end(), pairs.added.begin(), pairs.added.end());
    removed.insert(removed.end(), pairs.removed.begin(), pairs.removed.end());
  }
  std::sort(added.begin(), added.end());
  std::sort(removed.begin(), removed.end());
  added_pairs.clear();
  removed_pairs.clear();
  for (const std::uint64_t key : added) {
    added_pairs.push_back({static_cast<std::uint32_t>(key >> 32), static_cast<std::uint32_t>(key)});
  }
  for (const std::uint64_t key : removed) {
    removed_pairs.push_back(
        {static_cast<std::uint32_t>(key >> 32), static_cast<std::uint32_t>(key)});
  }
  // The full set + pending is this frame's set: a pair re-added cancels its
  // pending removal, a pair removed cancels its pending addition.
  std::vector<std::uint64_t> re_added, new_added, un_added, new_removed;
  std::set_intersection(added.begin(), added.end(), pending_removed_.begin(),
                        pending_removed_.end(), std::back_inserter(re_added));
  std::set_difference(added.begin(), added.end(), re_added.begin(), re_added.end(),
                      std::back_inserter(new_added));
  std::set_intersection(removed.begin(), removed.end(), pending_added_.begin(),
                        pending_added_.end(), std::back_inserter(un_added));
  std::set_difference(removed.begin(), removed.end(), un_added.begin(), un_added.end(),
                      std::back_inserter(new_removed));
  replaceSorted(pending_added_, un_added, new_added, scratch);
  replaceSorted(pending_removed_, re_added, new_removed, scratch);
}

void SapMovedBoxes::applyPendingChanges(PairSet& pairs) {
  if (pending_added_.empty() && pending_removed_.empty()) return;
  std::vector<std::uint64_t> keys;
  keys.reserve(pairs.size() + pending_added_.size());
  for (std::uint32_t a = 0; a < pairs.slotCount(); ++a) {
    for (const std::uint32_t b : pairs.partnersOf(a)) keys.push_back(pairKey(a, b));
  }
  std::vector<std::uint64_t> scratch;
  replaceSorted(keys, pending_removed_, pending_added_, scratch);
  const std::span<const std::uint64_t> batch[] = {keys};
  pairs.assign(pairs.slotCount(), batch);
  pending_added_.clear();
  pending_removed_.clear();
}

}  // namespace overlap::finders
