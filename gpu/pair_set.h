// PairSet: one frame's overlapping pairs, grouped by their lower slot, and
// the delta between two frames' sets, which is how cpusap
// (gpu/cpu_sap_pair_finder.h) reports what changed without asking Bullet's
// hash table.
//
// The pairs (a, b), a < b, are stored compressed by row: slot a's partners b
// are partners[offsets[a] .. offsets[a + 1]), in no particular order.
// Building it from the unordered pairs a search found is a counting sort on
// a: one pass to count, one to place.  The delta goes row by row: mark the
// old row's partners, look the new row's up, and what is left marked was
// removed; only the few changes of a row get sorted, so the added and the
// removed pairs come out sorted by (a, b).
//
// Invariants: no duplicates; every b < slotCount(); a slot at or above
// slotCount() has no partners (so a set over fewer slots compares with one
// over more, as when slots are added between frames).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "gpu/pair_finder.h"

namespace overlap::gpu {

// A pair as one 64-bit key, lower slot in the high half: keys sort as (a, b).
constexpr std::uint64_t pairKey(std::uint32_t x, std::uint32_t y) {
  const std::uint32_t a = x < y ? x : y;
  const std::uint32_t b = x < y ? y : x;
  return (std::uint64_t{a} << 32) | b;
}

class PairSet {
 public:
  // Replaces the set with the pairs in `batches`: pairKey()s over slots
  // [0, slot_count), each pair in at most one batch, at most once.
  void assign(std::uint32_t slot_count, std::span<const std::vector<std::uint64_t>* const> batches);

  std::uint32_t slotCount() const { return static_cast<std::uint32_t>(offsets_.size() - 1); }
  std::size_t size() const { return partners_.size(); }
  // Slot a's partners b > a, in no particular order; empty for a >= slotCount().
  std::span<const std::uint32_t> partnersOf(std::uint32_t a) const;

 private:
  std::vector<std::uint32_t> offsets_ = {0};  // slotCount() + 1 entries
  std::vector<std::uint32_t> partners_;
  std::vector<std::uint32_t> cursor_;  // scratch for assign()
};

// Appends the pairs of `current` missing from `previous` to `added` and those
// of `previous` missing from `current` to `removed`, both sorted by (a, b).
// `marks` is scratch, all zero between calls (it is left so).
void appendDelta(const PairSet& previous, const PairSet& current, std::vector<IndexPair>& added,
                 std::vector<IndexPair>& removed, std::vector<std::uint32_t>& marks);

}  // namespace overlap::gpu
