// cpubf: the brute-force pair finder on the CPU, the twin of the GPU finders.
//
// It keeps one bit per pair in 32-bit words (layout in gpu/pairs/pair_logic.h) and,
// each frame, recomputes every word, XORs it with last frame's and turns the
// changed bits into pairs.  The boxes are stored structure-of-arrays so that
// the test of one object against 32 others compiles to vector code, and the
// words are split into blocks that the caller's task system (gpu/task_system.h)
// spreads over its threads; a block owns its words, so no two threads write
// the same word, and each thread gathers its changes in a list of its own,
// sorted once merged, so the result does not depend on which thread took
// which block.  The whole search runs inside launch(); finish() only hands
// the result over.
// A signal (gpu/base/interrupt.h's flag) cuts a search short between blocks:
// its result is then partial and the finder's words are not last frame's;
// the caller stops (the world and the replay throw Interrupted) and only
// destroys the finder after it.  A frame adding more pairs than the pair
// limit stops the same way, between blocks, and finish() refuses it.
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

#include "gpu/pair_finder.h"
#include "gpu/task_system.h"

namespace overlap::finders {

class CpuBruteForceFinder final : public PairFinder {
 public:
  explicit CpuBruteForceFinder(TaskSystem& tasks = defaultTaskSystem());

  std::string_view name() const override { return "cpubf"; }

 private:
  void startSearch(std::span<const ObjectBounds> objects,
                   const std::span<const std::uint32_t>* changed) override;
  PairDelta finishSearch() override;
  SearchStats searchStats() const override { return stats_; }

  struct Changes {
    std::vector<IndexPair> added;
    std::vector<IndexPair> removed;
  };

  void storeObjects(std::span<const ObjectBounds> objects);
  // Recomputes words [first_word, end_word) and records the pairs that changed.
  void searchWords(std::uint64_t first_word, std::uint64_t end_word, Changes& changes);

  TaskSystem& tasks_;
  std::vector<Changes> thread_changes_;  // one a thread of tasks_, by threadIndex()

  std::uint32_t slot_count_ = 0;
  // One entry per slot, then padding so that 32 entries may be read from any
  // slot without a bounds check.
  std::vector<float> min_x_, min_y_, min_z_, max_x_, max_y_, max_z_;
  std::vector<std::int32_t> group_, mask_;
  std::vector<std::uint32_t> words_;  // last frame's bits, overwritten in place

  Changes result_;
  std::atomic<std::uint64_t> added_count_{0};  // this frame's added pairs, as found
  bool over_limit_ = false;                    // this frame added more than pairLimit()
  SearchStats stats_;                          // its search_ms only
};

}  // namespace overlap::finders
