#include "gpu/pairs/pair_set.h"

#include <algorithm>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>

namespace overlap::finders {

namespace {

// One counting pass of a stable radix sort over `parts` (in order), whose
// digit is digit(key) < digits: each part counts its digits, the counts
// become each (digit, part)'s first place, and each part places its keys.
// The parts count and place on `tasks`' threads when it is given; row_starts
// (if not empty) receives where each digit's keys start, and the total.
template <typename Digit, typename Place>
void countingPass(std::span<const std::span<const std::uint64_t>> parts, std::uint32_t digits,
                  TaskSystem* tasks, std::vector<std::vector<std::uint32_t>>& counts,
                  std::vector<std::uint32_t>* row_starts, const Digit& digit, const Place& place) {
  const auto forEachPart = [&](const auto& body) {
    if (tasks != nullptr) {
      tasks->forEachPiece(parts.size(), 1,
                          [&](std::size_t part, std::size_t /*end*/) { body(part); });
    } else {
      for (std::size_t part = 0; part < parts.size(); ++part) body(part);
    }
  };
  counts.resize(std::max(counts.size(), parts.size()));
  forEachPart([&](std::size_t part) {
    counts[part].assign(digits, 0);
    for (const std::uint64_t key : parts[part]) ++counts[part][digit(key)];
  });
  std::uint32_t start = 0;
  if (row_starts != nullptr) row_starts->resize(std::size_t{digits} + 1);
  for (std::uint32_t d = 0; d < digits; ++d) {
    if (row_starts != nullptr) (*row_starts)[d] = start;
    for (std::size_t part = 0; part < parts.size(); ++part) {
      start += std::exchange(counts[part][d], start);
    }
  }
  if (row_starts != nullptr) (*row_starts)[digits] = start;
  forEachPart([&](std::size_t part) {
    for (const std::uint64_t key : parts[part]) place(counts[part][digit(key)]++, key);
  });
}

}  // namespace

void PairSet::assign(std::uint32_t slot_count,
                     std::span<const std::span<const std::uint64_t>> batches, TaskSystem* tasks) {
  std::size_t total = 0;
  for (const std::span<const std::uint64_t> batch : batches) total += batch.size();
  if (total > std::numeric_limits<std::uint32_t>::max()) {
    throw std::runtime_error("PairSet: " + std::to_string(total) +
                             " pairs do not fit 32-bit row offsets");
  }
  // Pass 1, by b, the batches as they come.
  parts_.clear();
  for (const std::span<const std::uint64_t> batch : batches) {
    if (!batch.empty()) parts_.push_back(batch);
  }
  by_partner_.resize(total);
  countingPass(
      parts_, slot_count, tasks, counts_, nullptr,
      [](std::uint64_t key) { return static_cast<std::uint32_t>(key); },
      [&](std::uint32_t at, std::uint64_t key) { by_partner_[at] = key; });
  // Pass 2, by a, stable, over as many equal pieces of pass 1's output: each
  // row receives its partners in ascending order.
  const std::size_t pieces = std::max<std::size_t>(1, parts_.size());
  parts_.clear();
  for (std::size_t piece = 0; piece < pieces; ++piece) {
    parts_.push_back(std::span<const std::uint64_t>(by_partner_)
                         .subspan(total * piece / pieces,
                                  total * (piece + 1) / pieces - total * piece / pieces));
  }
  partners_.resize(total);
  countingPass(
      parts_, slot_count, tasks, counts_, &offsets_,
      [](std::uint64_t key) { return static_cast<std::uint32_t>(key >> 32); },
      [&](std::uint32_t at, std::uint64_t key) {
        partners_[at] = static_cast<std::uint32_t>(key);
      });
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

}  // namespace overlap::finders
