#include "gpu/pair_set.h"

#include <algorithm>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

namespace overlap::gpu {

void PairSet::assign(std::uint32_t slot_count,
                     std::span<const std::span<const std::uint64_t>> batches) {
  std::size_t total = 0;
  for (const std::span<const std::uint64_t> batch : batches) total += batch.size();
  if (total > std::numeric_limits<std::uint32_t>::max()) {
    throw std::runtime_error("PairSet: " + std::to_string(total) +
                             " pairs do not fit 32-bit row offsets");
  }
  // Pass 1, by b: count each b one slot to the right, so that the prefix
  // sum turns the counts into starts; then place the keys.
  cursor_.assign(std::size_t{slot_count} + 1, 0);
  for (const std::span<const std::uint64_t> batch : batches) {
    for (const std::uint64_t key : batch) ++cursor_[static_cast<std::uint32_t>(key) + 1];
  }
  std::partial_sum(cursor_.begin(), cursor_.end(), cursor_.begin());
  by_partner_.resize(total);
  for (const std::span<const std::uint64_t> batch : batches) {
    for (const std::uint64_t key : batch)
      by_partner_[cursor_[static_cast<std::uint32_t>(key)]++] = key;
  }
  // Pass 2, by a, stable: each row receives its partners in ascending order.
  offsets_.assign(std::size_t{slot_count} + 1, 0);
  for (const std::uint64_t key : by_partner_) ++offsets_[(key >> 32) + 1];
  std::partial_sum(offsets_.begin(), offsets_.end(), offsets_.begin());
  partners_.resize(total);
  cursor_.assign(offsets_.begin(), offsets_.end() - 1);
  for (const std::uint64_t key : by_partner_) {
    partners_[cursor_[key >> 32]++] = static_cast<std::uint32_t>(key);
  }
}

std::span<const std::uint32_t> PairSet::partnersOf(std::uint32_t a) const {
  if (a >= slotCount()) return {};
  return std::span(partners_).subspan(offsets_[a], offsets_[a + 1] - offsets_[a]);
}

void appendDelta(const PairSet& previous, const PairSet& current, std::uint32_t first,
                 std::uint32_t end, DeltaPart& part) {
  for (std::uint32_t a = first; a < end; ++a) {
    const std::span<const std::uint32_t> before = previous.partnersOf(a);
    const std::span<const std::uint32_t> now = current.partnersOf(a);
    if (before.size() == now.size()) {
      std::size_t same = 0;
      while (same < now.size() && before[same] == now[same]) ++same;
      if (same == now.size()) continue;  // most rows stay as they were
    }
    // A merge of the two sorted rows: what only `now` has was added, what
    // only `before` has was removed.
    std::size_t i = 0, j = 0;
    while (i < before.size() && j < now.size()) {
      if (before[i] == now[j]) {
        ++i;
        ++j;
      } else if (before[i] < now[j]) {
        part.removed.push_back({a, before[i++]});
      } else {
        part.added.push_back({a, now[j++]});
      }
    }
    for (; i < before.size(); ++i) part.removed.push_back({a, before[i]});
    for (; j < now.size(); ++j) part.added.push_back({a, now[j]});
  }
}

}  // namespace overlap::gpu
