// cpubf: the brute-force pair finder on the CPU, the twin of the GPU finders.
//
// It keeps one bit per pair in 32-bit words (layout in gpu/pairs/pair_logic.h) and,
// each frame, recomputes every word, XORs it with last frame's and turns the
// changed bits into pairs.  The boxes are stored structure-of-arrays so that
// the test of one object against 32 others compiles to vector code, and the
// words are split into blocks that oneTBB spreads over the threads; a block
// owns its words, so no two threads write the same word.  The whole search
// runs inside launch(); finish() only hands the result over.  It searches in
// an arena of its own, of that many threads or of as many as oneTBB allows,
// so that its demand for workers ends with it (a oneTBB thread cap lifted
// after the finder is gone starts no worker for it), as cpusap's does.
// A signal (gpu/base/interrupt.h's flag) cuts a search short between blocks:
// its result is then partial and the finder's words are not last frame's;
// the caller stops (the world and the replay throw Interrupted) and only
// destroys the finder after it.
#pragma once

#include <oneapi/tbb/enumerable_thread_specific.h>
#include <oneapi/tbb/task_arena.h>

#include <cstdint>
#include <vector>

#include "gpu/pair_finder.h"

namespace overlap::finders {

class CpuPairFinder final : public PairFinder {
 public:
  // threads = 0: every thread oneTBB allows.
  explicit CpuPairFinder(int threads = 0);

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

  tbb::task_arena arena_;
  tbb::enumerable_thread_specific<Changes> thread_changes_;

  std::uint32_t slot_count_ = 0;
  // One entry per slot, then padding so that 32 entries may be read from any
  // slot without a bounds check.
  std::vector<float> min_x_, min_y_, min_z_, max_x_, max_y_, max_z_;
  std::vector<std::int32_t> group_, mask_;
  std::vector<std::uint32_t> words_;  // last frame's bits, overwritten in place

  Changes result_;
  SearchStats stats_;  // its search_ms only
};

}  // namespace overlap::finders
