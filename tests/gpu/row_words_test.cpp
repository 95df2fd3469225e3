// gpubf's row-word layout and run walk (gpu/pairs/row_words.h), on the host: every
// pair has one bit, every run's rows are its column's, and the 64-bit index
// arithmetic stays exact past 2^32 pairs (n = 100000) and up to 2^32 slots.
#include "gpu/pairs/row_words.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <vector>

#include "gpu/pairs/pair_logic.h"

namespace overlap::finders {
namespace {

using row_words::columnCount;
using row_words::kRowsPerRun;
using row_words::rowStart;
using row_words::rowWords;
using row_words::runAt;
using row_words::runCount;

constexpr std::uint64_t kLargestSlotCount = 0xFFFFFFFFull;

TEST(RowWordsTest, RowStartIsTheSumOfTheRowsBeforeIt) {
  std::uint64_t words = 0;
  for (std::uint32_t b = 0; b <= 100000; ++b) {
    ASSERT_EQ(rowStart(b), words) << "b = " << b;
    ASSERT_EQ(rowWords(b), (b + 31ull) / 32) << "b = " << b;
    words += rowWords(b);
  }
}

TEST(RowWordsTest, RowStartStaysExactUpToTheLargestSlotCount) {
  // With rowStart(0) = 0, each step being one row's words makes it the sum.
  std::mt19937_64 random(29);
  std::vector<std::uint64_t> rows = {kLargestSlotCount - 1, kLargestSlotCount - 32,
                                     kLargestSlotCount - 33, 1ull << 31, (1ull << 32) - 64};
  for (int i = 0; i < 100000; ++i) rows.push_back(random() % kLargestSlotCount);
  for (const std::uint64_t b : rows) {
    ASSERT_EQ(rowStart(b + 1) - rowStart(b), rowWords(static_cast<std::uint32_t>(b)))
        << "b = " << b;
  }
  // The largest slot count, 32 q + 31: q groups of 32 rows, then 31 rows of
  // q + 1 words but the first (q words).  About 2^58 words, far from wrapping.
  const std::uint64_t q = kLargestSlotCount / 32;
  EXPECT_EQ(row_words::wordCount(kLargestSlotCount),
            (32 * q * (q - 1) / 2 + 31 * q) + (31 * (q + 1) - 1));
}

// Every pair (a, b) of n slots has one bit: the columns' valid lanes add up
// to the triangular pair count.
TEST(RowWordsTest, ColumnsHoldEveryPairOnce) {
  for (const std::uint64_t n :
       std::vector<std::uint64_t>{0, 1, 2, 31, 32, 33, 1023, 1025, 3500, 100000}) {
    std::uint64_t pairs = 0;
    for (std::uint64_t column = 0; column < columnCount(n); ++column) {
      const std::uint64_t rows = n - 1 - 32 * column;  // rows 32 column + 1 .. n - 1
      pairs += rows >= 31 ? 496 + 32 * (rows - 31) : rows * (rows + 1) / 2;
    }
    EXPECT_EQ(pairs, pair_logic::pairsBelow(n)) << "n = " << n;
  }
}

// The runs of n slots cover each column's rows 32 c + 1 .. n - 1 once, in
// order; a warp walking a run steps its word as the kernel does and ends on
// the column's word in the run's last row.
void expectRunsCoverTheTriangle(std::uint64_t n) {
  SCOPED_TRACE("n = " + std::to_string(n));
  const std::uint64_t columns = columnCount(n);
  std::vector<std::uint64_t> next_row(columns);
  for (std::uint64_t column = 0; column < columns; ++column) next_row[column] = 32 * column + 1;
  std::uint64_t words = 0;
  for (std::uint64_t r = 0; r < runCount(n); ++r) {
    const row_words::Run run = runAt(r, columns, n);
    ASSERT_LT(run.column, columns);
    if (run.first_row >= run.end_row) continue;
    ASSERT_EQ(run.first_row, next_row[run.column]) << "run " << r;
    ASSERT_LE(run.end_row - run.first_row, kRowsPerRun);
    next_row[run.column] = run.end_row;
    words += run.end_row - run.first_row;
    const std::uint64_t last_word = rowStart(run.end_row - 1) + run.column;
    ASSERT_LT(last_word, row_words::wordCount(n));
    ASSERT_LT(run.column, rowWords(static_cast<std::uint32_t>(run.end_row - 1)));
  }
  for (std::uint64_t column = 0; column < columns; ++column) {
    ASSERT_EQ(next_row[column], n) << "column " << column;
  }
  EXPECT_EQ(words, row_words::wordCount(n));
}

TEST(RowWordsTest, RunsCoverEveryWordOnceAtTheTestedSizes) {
  for (const std::uint64_t n : std::vector<std::uint64_t>{0, 1, 2, 31, 32, 33, 1023, 1025, 3500}) {
    expectRunsCoverTheTriangle(n);
  }
}

TEST(RowWordsTest, RunsCoverEveryWordOncePastTwoToTheThirtyTwoPairs) {
  constexpr std::uint64_t kSlots = 100000;
  ASSERT_GT(pair_logic::pairsBelow(kSlots), 1ull << 32);
  expectRunsCoverTheTriangle(kSlots);
}

TEST(RowWordsTest, TheLastRunsOfTheLargestSlotCountStayInRange) {
  const std::uint64_t n = kLargestSlotCount;
  const std::uint64_t columns = columnCount(n);
  for (std::uint64_t r = runCount(n) - 3 * columns; r < runCount(n); r += columns / 7 + 1) {
    const row_words::Run run = runAt(r, columns, n);
    ASSERT_LE(run.end_row, n);
    if (run.first_row >= run.end_row) continue;
    ASSERT_GT(run.first_row, 32 * run.column);
    EXPECT_LT(rowStart(run.end_row - 1) + run.column, row_words::wordCount(n));
  }
  EXPECT_EQ(runAt(runCount(n) - 1, columns, n).end_row, n);
}

}  // namespace
}  // namespace overlap::finders
