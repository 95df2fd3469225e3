#include "gpu/cpu/cpu_brute_force.h"

#include <algorithm>
#include <array>
#include <bit>
#include <stdexcept>
#include <string>

#include "gpu/base/interrupt.h"
#include "gpu/pairs/pair_logic.h"

namespace overlap::finders {
namespace {

using pair_logic::kBitsPerWord;

// Words per parallel task: large enough to amortize the task and the decoding
// of its first pair, small enough to balance two to a few dozen threads.
constexpr std::uint64_t kBlockWords = 256;
// Pieces of blocks a thread: enough that a thread slowed by another job
// leaves its share to the others.
constexpr std::size_t kPiecesPerThread = 8;

// On x86-64 the search is built twice, for the baseline and for AVX2, and the
// loader picks one: the box tests are vectorized, so eight float lanes do in
// one step what four do in two (docs/results/run_costs.md has the figure).  Not
// under ThreadSanitizer: GCC's instrumented ifunc resolver runs before the
// TSan runtime is up and crashes the program before main.
#if defined(__x86_64__) && !defined(__SANITIZE_THREAD__)
#define OVERLAP_VECTOR_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define OVERLAP_VECTOR_CLONES
#endif

// kBitOf[k] = 1 << k.  Selecting a bit from a table, where a shift by the
// loop counter would do, is what lets GCC vectorize chunkBits on baseline SSE2.
constexpr auto kBitOf = [] {
  std::array<std::uint32_t, kBitsPerWord> bits{};
  for (std::uint32_t k = 0; k < kBitsPerWord; ++k) bits[k] = 1u << k;
  return bits;
}();

void appendPairs(std::uint32_t bits, std::uint64_t word, std::vector<IndexPair>& pairs) {
  while (bits != 0) {
    const auto bit = static_cast<std::uint64_t>(std::countr_zero(bits));
    pairs.push_back(pair_logic::pairAt(word * kBitsPerWord + bit));
    bits &= bits - 1;
  }
}

// One slot's box and filter, as loaded once per row.
struct Slot {
  float min_x, min_y, min_z, max_x, max_y, max_z;
  std::int32_t group, mask;
};

// The structure-of-arrays columns, read-only.
struct Columns {
  const float *min_x, *min_y, *min_z, *max_x, *max_y, *max_z;
  const std::int32_t *group, *mask;

  Slot at(std::uint32_t i) const {
    return {min_x[i], min_y[i], min_z[i], max_x[i], max_y[i], max_z[i], group[i], mask[i]};
  }
};

// Bits of pairs (a, b) for a = first_a .. first_a + 31: bit k is a = first_a + k.
// Fixed trip count, no branches, no shift by k, pointers offset up front
// (an unsigned index could wrap, which defeats contiguous vector loads):
// this loop vectorizes.
inline std::uint32_t chunkBits(const Columns& columns, const Slot& b, std::uint32_t first_a) {
  const float* const min_x = columns.min_x + first_a;
  const float* const min_y = columns.min_y + first_a;
  const float* const min_z = columns.min_z + first_a;
  const float* const max_x = columns.max_x + first_a;
  const float* const max_y = columns.max_y + first_a;
  const float* const max_z = columns.max_z + first_a;
  const std::int32_t* const group = columns.group + first_a;
  const std::int32_t* const mask = columns.mask + first_a;
  std::uint32_t bits = 0;
  for (std::uint32_t k = 0; k < kBitsPerWord; ++k) {
    const bool pairs = pair_logic::intervalsOverlap(min_x[k], max_x[k], b.min_x, b.max_x) &
                       pair_logic::intervalsOverlap(min_y[k], max_y[k], b.min_y, b.max_y) &
                       pair_logic::intervalsOverlap(min_z[k], max_z[k], b.min_z, b.max_z) &
                       pair_logic::filtersAccept(group[k], mask[k], b.group, b.mask);
    bits |= (0u - static_cast<std::uint32_t>(pairs)) & kBitOf[k];
  }
  return bits;
}

}  // namespace

CpuBruteForceFinder::CpuBruteForceFinder(TaskSystem& tasks)
    : tasks_(tasks), thread_changes_(static_cast<std::size_t>(tasks.threads())) {}

void CpuBruteForceFinder::storeObjects(std::span<const ObjectBounds> objects) {
  const std::size_t padded = objects.size() + kBitsPerWord;
  for (auto* column : {&min_x_, &min_y_, &min_z_, &max_x_, &max_y_, &max_z_}) {
    column->resize(padded, 0.0f);
  }
  group_.resize(padded, 0);
  mask_.resize(padded, 0);
  for (std::size_t i = 0; i < objects.size(); ++i) {
    const ObjectBounds& object = objects[i];
    min_x_[i] = object.min[0];
    min_y_[i] = object.min[1];
    min_z_[i] = object.min[2];
    max_x_[i] = object.max[0];
    max_y_[i] = object.max[1];
    max_z_[i] = object.max[2];
    group_[i] = object.group;
    mask_[i] = object.mask;
  }
}

OVERLAP_VECTOR_CLONES void CpuBruteForceFinder::searchWords(std::uint64_t first_word,
                                                            std::uint64_t end_word,
                                                            Changes& changes) {
  std::array<std::uint32_t, kBlockWords> fresh{};
  const Columns columns{min_x_.data(), min_y_.data(), min_z_.data(), max_x_.data(),
                        max_y_.data(), max_z_.data(), group_.data(), mask_.data()};
  const std::uint64_t end_pair =
      std::min(end_word * kBitsPerWord, pair_logic::pairsBelow(slot_count_));
  std::uint64_t p = first_word * kBitsPerWord;
  const IndexPair first = pair_logic::pairAt(p);
  std::uint32_t a = first.a;
  // Walk the rows that cross this block, one word-aligned run at a time, so
  // that each run's bits land in a single word.
  for (std::uint32_t b = first.b; p < end_pair; ++b, a = 0) {
    const std::uint64_t row_end = std::min(pair_logic::pairsBelow(b + 1ull), end_pair);
    const Slot row = columns.at(b);
    if (row.group == 0 || row.mask == 0) {  // an unused slot pairs with nothing
      p = row_end;
      continue;
    }
    while (p < row_end) {
      const auto offset = static_cast<std::uint32_t>(p % kBitsPerWord);
      const auto length =
          static_cast<std::uint32_t>(std::min<std::uint64_t>(kBitsPerWord - offset, row_end - p));
      const std::uint32_t keep = length == kBitsPerWord ? ~0u : (1u << length) - 1u;
      fresh[p / kBitsPerWord - first_word] |= (chunkBits(columns, row, a) & keep) << offset;
      p += length;
      a += length;
    }
  }
  for (std::uint64_t word = first_word; word < end_word; ++word) {
    const std::uint32_t previous = words_[word];
    const std::uint32_t current = fresh[word - first_word];
    if (previous == current) continue;
    words_[word] = current;
    appendPairs(pair_logic::addedBits(previous, current), word, changes.added);
    appendPairs(pair_logic::removedBits(previous, current), word, changes.removed);
  }
}

void CpuBruteForceFinder::startSearch(std::span<const ObjectBounds> objects,
                                      const std::span<const std::uint32_t>* /*changed*/) {
  slot_count_ = checkedSlotCount(name(), slot_count_, objects.size());
  storeObjects(objects);
  // New words start at zero: new slots had no pairs last frame.
  words_.resize(pair_logic::wordCount(pair_logic::pairsBelow(slot_count_)), 0u);

  for (Changes& changes : thread_changes_) {
    changes.added.clear();
    changes.removed.clear();
  }
  const std::uint64_t word_count = words_.size();
  const std::uint64_t block_count = (word_count + kBlockWords - 1) / kBlockWords;
  // The pieces' bounds do not matter to the result (it is sorted below).
  const std::size_t grain = grainFor(block_count, tasks_.threads(), kPiecesPerThread, 1);
  // Added pairs only: the removed ones were last frame's, within the limit.
  added_count_.store(0, std::memory_order_relaxed);
  const std::uint64_t most = pairLimit();
  tasks_.forEachPiece(block_count, grain, [&](std::size_t first_block, std::size_t end_block) {
    Changes& changes = thread_changes_[static_cast<std::size_t>(tasks_.threadIndex())];
    for (std::size_t block = first_block; block != end_block; ++block) {
      // A signal cuts a long search short (the caller stops:
      // gpu/base/interrupt.h), and so does passing the pair limit; the words
      // left are not searched.
      if (pendingInterrupt() != 0 || added_count_.load(std::memory_order_relaxed) > most) return;
      const std::uint64_t first_word = block * kBlockWords;
      const std::size_t before = changes.added.size();
      searchWords(first_word, std::min(first_word + kBlockWords, word_count), changes);
      added_count_.fetch_add(changes.added.size() - before, std::memory_order_relaxed);
    }
  });
  over_limit_ = added_count_.load(std::memory_order_relaxed) > most;
  if (over_limit_) {
    stats_.search_ms = msSinceLaunch();
    return;
  }

  result_.added.clear();
  result_.removed.clear();
  for (const Changes& changes : thread_changes_) {
    result_.added.insert(result_.added.end(), changes.added.begin(), changes.added.end());
    result_.removed.insert(result_.removed.end(), changes.removed.begin(), changes.removed.end());
  }
  std::sort(result_.added.begin(), result_.added.end());
  std::sort(result_.removed.begin(), result_.removed.end());
  stats_.search_ms = msSinceLaunch();
}

PairDelta CpuBruteForceFinder::finishSearch() {
  if (over_limit_) throw pairLimitError();
  return PairDelta{result_.added, result_.removed};
}

}  // namespace overlap::finders
