// Row words: gpubf's layout of the pair bits, and how its warps walk them.
// One source for the host and, under nvcc, the device.
//
// Row b (the pairs (a, b), a < b) starts on a word of its own and fills
// ceil(b / 32) words: bit `lane` of word rowStart(b) + column holds the pair
// (32 * column + lane, b), and the bits with a >= b are always zero.  A word
// thus holds 32 consecutive a of one b, so a warp whose lane `lane` keeps box
// A = 32 * column + lane in registers walks down a column (b, b + 1, ...) and
// loads only box B per word, the same address for every lane: box A is loaded
// once per run of rows, not once per pair.  Like gpu/pairs/pair_logic.h's
// numbering, rowStart(b) does not depend on the slot count, so growing n
// appends rows and every stored bit keeps its place.
//
// The work is cut into runs: run (column, slice) covers that column's rows in
// [slice * kRowsPerRun, (slice + 1) * kRowsPerRun), clipped to the rows that
// have the column (b > 32 * column) and to b < n.  Runs whose rows are all
// clipped away (above the diagonal) are empty.  The run index orders columns
// fastest, so the warps working at one time read neighbouring B boxes.
//
// All index arithmetic is 64-bit and exact for every n <= 2^32 (word counts
// below 2^58); checked on the host at n = 100000 (5e9 pairs, past 2^32) and
// near 2^32 in tests/gpu/row_words_test.cpp.
#pragma once

#include <cstdint>

#include "gpu/pairs/pair_logic.h"

namespace overlap::finders::row_words {

using pair_logic::kBitsPerWord;

// Rows per run: the decode of a run's start, and the load of its A boxes,
// are shared by this many words.
inline constexpr std::uint32_t kRowsPerRun = 64;

// Words in row b: ceil(b / 32), without overflow for any 32-bit b.
OVERLAP_HD constexpr std::uint32_t rowWords(std::uint32_t b) {
  return b / kBitsPerWord + (b % kBitsPerWord != 0 ? 1u : 0u);
}

// The first word of row b: the sum of rowWords(r) for r < b.  With
// b = 32 q + s, the q full groups of 32 rows give 32 q (q - 1) / 2 + 31 q
// words and the s rows after them s q + s - 1 (none when s = 0).
OVERLAP_HD constexpr std::uint64_t rowStart(std::uint64_t b) {
  const std::uint64_t q = b / kBitsPerWord;
  const std::uint64_t s = b % kBitsPerWord;
  const std::uint64_t full = 16 * q * (q == 0 ? 0 : q - 1) + 31 * q;
  return full + (s == 0 ? 0 : s * q + s - 1);
}

// Words for rows 0..n-1: the length of the bit buffers at n slots.
OVERLAP_HD constexpr std::uint64_t wordCount(std::uint64_t n) {
  return rowStart(n);
}

// Columns at n slots: the words of the longest row, n - 1.
OVERLAP_HD constexpr std::uint64_t columnCount(std::uint64_t n) {
  return n < 2 ? 0 : rowWords(static_cast<std::uint32_t>(n - 1));
}

// Row slices at n slots: ceil(n / kRowsPerRun).
OVERLAP_HD constexpr std::uint64_t sliceCount(std::uint64_t n) {
  return (n + kRowsPerRun - 1) / kRowsPerRun;
}

// Runs at n slots, empty ones included.
OVERLAP_HD constexpr std::uint64_t runCount(std::uint64_t n) {
  return columnCount(n) * sliceCount(n);
}

// One run: its column and the rows [first_row, end_row) it covers (none when
// first_row >= end_row).
struct Run {
  std::uint64_t column;
  std::uint64_t first_row;
  std::uint64_t end_row;
};

OVERLAP_HD constexpr Run runAt(std::uint64_t run, std::uint64_t columns, std::uint64_t n) {
  const std::uint64_t column = run % columns;
  const std::uint64_t slice = run / columns;
  const std::uint64_t slice_start = slice * kRowsPerRun;
  const std::uint64_t first_row_with_column = kBitsPerWord * column + 1;
  const std::uint64_t first =
      slice_start > first_row_with_column ? slice_start : first_row_with_column;
  const std::uint64_t slice_end = slice_start + kRowsPerRun;
  return Run{column, first, slice_end < n ? slice_end : n};
}

}  // namespace overlap::finders::row_words
