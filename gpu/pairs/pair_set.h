// PairSet: one frame's overlapping pairs, grouped by their lower slot, and
// the delta between two frames' sets, which is how cpusap
// (gpu/cpu/cpu_sweep_and_prune.h) reports what changed without asking Bullet's
// hash table.
//
// The pairs (a, b), a < b, are stored compressed by row: slot a's partners b
// are partners[offsets[a] .. offsets[a + 1]), sorted.  Building it from the
// unordered pairs a search found is a two-pass radix sort whose digits are
// whole slots: by b, then (stably) by a; each pass counts, then places, each
// batch (then each piece) on its own thread if asked.  The delta then goes
// row by row: a row equal to last frame's (most are) is skipped, the others
// are merged, so the added and the removed pairs come out sorted by (a, b).
// Rows are independent: ranges of them can be compared on several threads.
//
// Invariants: no duplicates; every b < slotCount(); a slot at or above
// slotCount() has no partners (so a set over fewer slots compares with one
// over more, as when slots are added between frames).
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "gpu/pairs/pair_types.h"

namespace overlap::finders {

// The pair keys a search appends, kept from frame to frame so that it
// allocates only while it grows.  The sweep's AVX2 kernel writes a whole
// vector of keys at once and then keeps as many as it found.
// A frame's lists may share a KeyLimit: each counts its keys into `found`
// when it must grow, and once `found` passes `most` it drops its keys
// instead of growing, so the lists stay near `most` keys in all whatever the
// frame holds.  The caller then refuses the frame (exceeded()).  Counting
// only when growing keeps the sweep free of shared writes.
struct KeyLimit {
  std::atomic<std::uint64_t> found{0};
  std::uint64_t most = UINT64_MAX;
  bool exceeded() const { return found.load(std::memory_order_relaxed) > most; }
};

class PairKeys {
 public:
  void clear() { count_ = reported_ = 0; }
  // Counts into `limit` from now on (null: none); it must outlive its use.
  void limitBy(KeyLimit* limit) { limit_ = limit; }
  std::size_t size() const { return count_; }
  // Room for `more` keys from the end: write them there, then commit().
  std::uint64_t* room(std::size_t more) {
    if (count_ + more > storage_.size()) grow(more);
    return storage_.data() + count_;
  }
  void commit(std::size_t written) { count_ += written; }
  void push_back(std::uint64_t key) {
    *room(1) = key;
    ++count_;
  }
  std::span<const std::uint64_t> keys() const { return {storage_.data(), count_}; }

 private:
  void grow(std::size_t more) {
    if (limit_ != nullptr) {
      limit_->found.fetch_add(count_ - reported_, std::memory_order_relaxed);
      reported_ = count_;
      if (limit_->exceeded()) {  // a refused frame: its keys are dropped
        count_ = reported_ = 0;
        if (more <= storage_.size()) return;
      }
    }
    storage_.resize(std::max({2 * storage_.size(), count_ + more, std::size_t{1024}}));
  }

  std::vector<std::uint64_t> storage_;  // its size is the capacity
  std::size_t count_ = 0;
  std::size_t reported_ = 0;  // of count_, counted into limit_
  KeyLimit* limit_ = nullptr;
};

class PairSet {
 public:
  // Runs part(k) once for each k < parts, perhaps several at once on other
  // threads, and returns when all have ended (the caller's task system:
  // gpu/task_system.h, which this layer does not see).
  using ForEachPart =
      std::function<void(std::size_t parts, const std::function<void(std::size_t)>& part)>;

  // Replaces the set with the pairs in `batches`: pairKey()s over slots
  // [0, slot_count), each pair in at most one batch, at most once.  With
  // `for_each_part`, the batches are counted and placed through it, a batch
  // a part; the set is the same either way.
  void assign(std::uint32_t slot_count, std::span<const std::span<const std::uint64_t>> batches,
              const ForEachPart* for_each_part = nullptr);

  std::uint32_t slotCount() const { return static_cast<std::uint32_t>(offsets_.size() - 1); }
  std::size_t size() const { return partners_.size(); }
  // Slot a's partners b > a, sorted; empty for a >= slotCount().
  std::span<const std::uint32_t> partnersOf(std::uint32_t a) const;

 private:
  std::vector<std::uint32_t> offsets_ = {0};  // slotCount() + 1 entries
  std::vector<std::uint32_t> partners_;
  // Scratch for assign(): the keys sorted by b, the pieces of a pass, and
  // each piece's counts.
  std::vector<std::uint64_t> by_partner_;
  std::vector<std::span<const std::uint64_t>> parts_;
  std::vector<std::vector<std::uint32_t>> counts_;
};

// The delta of a range of rows: one per range when ranges are computed at
// the same time.
struct DeltaPart {
  std::vector<IndexPair> added, removed;
};

// Appends the pairs (a, b), a in [first, end), of `current` missing from
// `previous` to part.added and those of `previous` missing from `current` to
// part.removed, both sorted by (a, b).
void appendDelta(const PairSet& previous, const PairSet& current, std::uint32_t first,
                 std::uint32_t end, DeltaPart& part);

}  // namespace overlap::finders
