#include "gpu/pair_set.h"

#include <algorithm>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

namespace overlap::gpu {

void PairSet::assign(std::uint32_t slot_count,
                     std::span<const std::vector<std::uint64_t>* const> batches) {
  std::size_t total = 0;
  for (const std::vector<std::uint64_t>* batch : batches) total += batch->size();
  if (total > std::numeric_limits<std::uint32_t>::max()) {
    throw std::runtime_error("PairSet: " + std::to_string(total) +
                             " pairs do not fit 32-bit row offsets");
  }
  // Count each row's pairs, one slot to the right, so that the prefix sum
  // turns the counts into row starts; then place each pair's b in its row.
  offsets_.assign(std::size_t{slot_count} + 1, 0);
  for (const std::vector<std::uint64_t>* batch : batches) {
    for (const std::uint64_t key : *batch) ++offsets_[(key >> 32) + 1];
  }
  std::partial_sum(offsets_.begin(), offsets_.end(), offsets_.begin());
  partners_.resize(offsets_.back());
  cursor_.assign(offsets_.begin(), offsets_.end() - 1);
  for (const std::vector<std::uint64_t>* batch : batches) {
    for (const std::uint64_t key : *batch) {
      partners_[cursor_[key >> 32]++] = static_cast<std::uint32_t>(key);
    }
  }
}

std::span<const std::uint32_t> PairSet::partnersOf(std::uint32_t a) const {
  if (a >= slotCount()) return {};
  return std::span(partners_).subspan(offsets_[a], offsets_[a + 1] - offsets_[a]);
}

void appendDelta(const PairSet& previous, const PairSet& current, std::vector<IndexPair>& added,
                 std::vector<IndexPair>& removed, std::vector<std::uint32_t>& marks) {
  const std::uint32_t slots = std::max(previous.slotCount(), current.slotCount());
  if (marks.size() < slots) marks.resize(slots, 0);
  for (std::uint32_t a = 0; a < slots; ++a) {
    const std::span<const std::uint32_t> before = previous.partnersOf(a);
    const std::span<const std::uint32_t> now = current.partnersOf(a);
    if (before.empty() && now.empty()) continue;
    // a + 1 marks "in row a last frame" (a < slots <= 2^32 - 1, so no wrap);
    // a partner found again is unmarked, and the rest are cleared on the way
    // out, so that marks is all zero for the next row.
    const std::uint32_t mark = a + 1;
    for (const std::uint32_t b : before) marks[b] = mark;
    const std::size_t first_added = added.size(), first_removed = removed.size();
    for (const std::uint32_t b : now) {
      if (marks[b] == mark) {
        marks[b] = 0;
      } else {
        added.push_back({a, b});
      }
    }
    for (const std::uint32_t b : before) {
      if (marks[b] == mark) removed.push_back({a, b});
      marks[b] = 0;
    }
    std::sort(added.begin() + static_cast<std::ptrdiff_t>(first_added), added.end());
    std::sort(removed.begin() + static_cast<std::ptrdiff_t>(first_removed), removed.end());
  }
}

}  // namespace overlap::gpu
