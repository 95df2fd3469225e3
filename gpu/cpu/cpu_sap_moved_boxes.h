// cpusap's moved-box path (gpu/cpu/cpu_sap_pair_finder.h): a frame in which few
// boxes changed costs in proportion to them and their pairs.
//
// The boxes that differ from the last frame's are found among the caller's
// changed slots or else by comparing every box, and only they are queried,
// each at its old and its new bounds, against the last full frame's layout
// (for the boxes unchanged since) and against a small layout of the boxes
// changed since (the "dirty" ones); the pairs that differ between the two
// queries are the delta.  Its cost follows the moved boxes and their pairs
// (plus one comparison of each box's bytes when the caller did not say which
// changed).
//
// Rules, each with its reason:
// - It answers only after a full frame without inverted boxes, for the same
//   slot count, while the dirty boxes are at most a share of all and no
//   moved box is inverted: past that share a full search is cheaper (each
//   moved box costs two queries, and the dirty layouts are rebuilt every
//   frame), and an inverted box cannot be laid out.
// - A caller's changed slots are trusted only when the search before this
//   one finished: a search that threw may have left its boxes' kept bounds
//   behind, and the list names only what changed since that search.
// - Its deltas are pending changes to the full search's pair set, folded in
//   (applyPendingChanges) before the next full search compares against it:
//   that set plus the pending changes is always the last frame's pairs.
// - The same inclusive test and filters as the full search (the layouts'
//   query()), so the delta is exact.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "gpu/pair_finder.h"
#include "gpu/pairs/pair_set.h"
#include "gpu/pairs/sap_sweep.h"
#include "gpu/task_system.h"

namespace overlap::finders {

class SapMovedBoxes {
 public:
  // What the last full search left: its layout (indexed for queries), the
  // axes it swept and cut, its slabs.
  struct FullFrame {
    const sap::SweepLayout& layout;
    const sap::SlabGrid& grid;
    int sweep_axis;
    int slab_axis;
  };

  // Queries run on `tasks`' threads; it must outlive this.
  explicit SapMovedBoxes(TaskSystem& tasks)
      : tasks_(tasks), moved_pairs_(static_cast<std::size_t>(tasks.threads())) {}

  // This frame's delta, sorted, into `added` and `removed`, and the phases'
  // times, when few enough boxes moved since the full frame; false, with
  // nothing written, when a full search must run.  changed: the caller's
  // changed slots, or null to compare every box.  Throws std::runtime_error
  // for a changed slot past the boxes.
  bool search(std::span<const ObjectBounds> objects, const std::span<const std::uint32_t>* changed,
              const FullFrame& full, std::vector<IndexPair>& added, std::vector<IndexPair>& removed,
              SearchPhases& phases);
  // The search that began with search() has finished, either path.
  void searchFinished() { kept_current_ = true; }
  // Folds the moved-box frames' changes into `pairs`, the full search's last set.
  void applyPendingChanges(PairSet& pairs);
  // After a full search of `objects`: its boxes become the reference for the
  // next moved-box frames; `any_inverted` rules them out until the next one.
  void keepFullFrame(std::span<const ObjectBounds> objects, bool any_inverted);

 private:
  struct MovedPairs {
    std::vector<std::uint32_t> before, now;  // one query's hits
    std::vector<std::uint64_t> added, removed;
  };

  bool findMovedBoxes(std::span<const ObjectBounds> objects,
                      const std::span<const std::uint32_t>* changed);
  // Whether the slot's box is a moved one; false when this path cannot take it.
  bool noteIfMoved(std::span<const ObjectBounds> objects, std::uint32_t slot, std::size_t limit);
  void layOutDirtyBoxes(std::span<const ObjectBounds> objects, const FullFrame& full,
                        sap::SweepLayout& layout);
  void queryMovedBoxes(std::span<const ObjectBounds> objects, const FullFrame& full);
  // The queries' pairs, sorted, into `added` and `removed`, and into the pending changes.
  void collectDelta(std::vector<IndexPair>& added, std::vector<IndexPair>& removed);

  TaskSystem& tasks_;
  bool have_full_frame_ = false;
  // Every slot's bounds as last searched: the last launch's boxes when it
  // finished (kept_current_), so its caller's changed slots are all that differ.
  std::vector<ObjectBounds> kept_;
  bool kept_current_ = false;
  std::vector<std::uint8_t> dirty_flag_;       // per slot: changed since the full frame
  std::vector<std::uint32_t> dirty_;           // those slots
  std::vector<std::uint8_t> moved_flag_;       // per slot: changed this frame
  std::vector<std::uint32_t> moved_;           // those slots
  sap::SweepLayout dirty_before_, dirty_now_;  // the dirty boxes at kept_ and now
  std::vector<std::uint64_t> dirty_entries_;
  std::vector<MovedPairs> moved_pairs_;  // one a thread of tasks_, by threadIndex()
  std::vector<std::uint64_t> pending_added_, pending_removed_;  // since the full set was built
};

}  // namespace overlap::finders
