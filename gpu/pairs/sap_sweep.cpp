#include "gpu/pairs/sap_sweep.h"

#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "gpu/pairs/pair_logic.h"
#include "gpu/pairs/pair_set.h"

#if defined(__x86_64__)
#include <immintrin.h>
#define OVERLAP_HAVE_AVX2_KERNEL 1
#else
#define OVERLAP_HAVE_AVX2_KERNEL 0
#endif

namespace overlap::finders::sap {
namespace {

// The layout's columns, as the kernels read them.
struct Columns {
  const float* sweep_min;
  const float* sweep_max;
  const float* other_min[2];
  const float* other_max[2];
  const std::int32_t* group;
  const std::int32_t* mask;
  const std::int32_t* starts_here;
  const std::uint32_t* slot;
};

// Entry i, as its scan reads it once.
struct Scanner {
  float sweep_max;
  float other_min[2];
  float other_max[2];
  std::int32_t group;
  std::int32_t mask;
  std::int32_t starts_here;
  std::uint32_t slot;

  Scanner(const Columns& c, std::uint32_t i)
      : sweep_max(c.sweep_max[i]),
        other_min{c.other_min[0][i], c.other_min[1][i]},
        other_max{c.other_max[0][i], c.other_max[1][i]},
        group(c.group[i]),
        mask(c.mask[i]),
        starts_here(c.starts_here[i]),
        slot(c.slot[i]) {}
};

void sweepScalar(const Columns& c, std::uint32_t first, std::uint32_t end, PairKeys& pairs) {
  for (std::uint32_t i = first; i < end; ++i) {
    const Scanner a(c, i);
    // The padding's NaN fails the comparison and ends the scan.
    for (std::uint32_t j = i + 1; c.sweep_min[j] <= a.sweep_max; ++j) {
      const bool pairs_with = pair_logic::intervalsOverlap(a.other_min[0], a.other_max[0],
                                                           c.other_min[0][j], c.other_max[0][j]) &
                              pair_logic::intervalsOverlap(a.other_min[1], a.other_max[1],
                                                           c.other_min[1][j], c.other_max[1][j]) &
                              pair_logic::filtersAccept(a.group, a.mask, c.group[j], c.mask[j]) &
                              ((a.starts_here | c.starts_here[j]) != 0);
      if (pairs_with) pairs.push_back(pairKey(a.slot, c.slot[j]));
    }
  }
}

#if OVERLAP_HAVE_AVX2_KERNEL

__attribute__((target("avx2"))) inline __m256i loadInts(const std::int32_t* p) {
  return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
}

// kKeepKeys[m]: the 32-bit lane indices that move the 64-bit keys selected
// by the 4-bit mask m to the front of a vector of four, in order.
constexpr auto kKeepKeys = [] {
  std::array<std::array<std::int32_t, 8>, 16> table{};
  for (std::uint32_t m = 0; m < 16; ++m) {
    std::uint32_t kept = 0;
    for (std::int32_t key = 0; key < 4; ++key) {
      if ((m >> key) & 1) {
        table[m][2 * kept] = 2 * key;
        table[m][2 * kept + 1] = 2 * key + 1;
        ++kept;
      }
    }
  }
  return table;
}();

// Appends the pairKey()s of (a_slot, slots[k]) for the lanes k set in
// `lanes`, without a branch per pair: the keys are built in two vectors of
// four, each compacted by a table lookup and stored whole.
__attribute__((target("avx2"))) inline void appendKeys(__m256i a_slot, __m256i slots, int lanes,
                                                       PairKeys& pairs) {
  const __m256i low = _mm256_min_epu32(a_slot, slots);
  const __m256i high = _mm256_max_epu32(a_slot, slots);
  // Interleaving (high, low) makes 64-bit keys high | low << 32: lanes 0, 1,
  // 4, 5 in the first vector, 2, 3, 6, 7 in the second.
  const __m256i keys[2] = {_mm256_unpacklo_epi32(high, low), _mm256_unpackhi_epi32(high, low)};
  const auto bits = static_cast<unsigned>(lanes);
  const unsigned selected[2] = {(bits & 3u) | ((bits >> 2) & 12u),
                                ((bits >> 2) & 3u) | ((bits >> 4) & 12u)};
  std::uint64_t* out = pairs.room(kLanes);
  std::size_t written = 0;
  for (int half = 0; half < 2; ++half) {
    const __m256i order =
        _mm256_loadu_si256(reinterpret_cast<const __m256i*>(kKeepKeys[selected[half]].data()));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + written),
                        _mm256_permutevar8x32_epi32(keys[half], order));
    written += static_cast<std::size_t>(std::popcount(selected[half]));
  }
  pairs.commit(written);
}

// The scalar kernel's tests on eight candidates j .. j + 7 at once.  The
// comparisons are ordered and non-signalling (_CMP_LE_OQ): false on NaN, as
// the scalar '<=' is.
__attribute__((target("avx2"))) void sweepAvx2(const Columns& c, std::uint32_t first,
                                               std::uint32_t end, PairKeys& pairs) {
  // Local copies: the compiler need not reload them after each store of keys.
  const float* const sweep_min = c.sweep_min;
  const float *const other_min0 = c.other_min[0], *const other_max0 = c.other_max[0];
  const float *const other_min1 = c.other_min[1], *const other_max1 = c.other_max[1];
  const std::int32_t *const their_groups = c.group, *const their_masks = c.mask;
  const std::int32_t* const their_starts = c.starts_here;
  const auto* const slots = reinterpret_cast<const std::int32_t*>(c.slot);
  const __m256i zero = _mm256_setzero_si256();
  for (std::uint32_t i = first; i < end; ++i) {
    const Scanner a(c, i);
    const __m256 sweep_max = _mm256_set1_ps(a.sweep_max);
    const __m256 min0 = _mm256_set1_ps(a.other_min[0]), max0 = _mm256_set1_ps(a.other_max[0]);
    const __m256 min1 = _mm256_set1_ps(a.other_min[1]), max1 = _mm256_set1_ps(a.other_max[1]);
    for (std::uint32_t j = i + 1;; j += kLanes) {
      // Sorted order makes the candidates inside i's extent a prefix of the
      // eight lanes; the scan goes on only while all eight are inside.
      const __m256 inside = _mm256_cmp_ps(_mm256_loadu_ps(sweep_min + j), sweep_max, _CMP_LE_OQ);
      const int inside_bits = _mm256_movemask_ps(inside);
      if (inside_bits == 0) break;
      __m256 hit =
          _mm256_and_ps(inside, _mm256_cmp_ps(_mm256_loadu_ps(other_min0 + j), max0, _CMP_LE_OQ));
      hit = _mm256_and_ps(hit, _mm256_cmp_ps(min0, _mm256_loadu_ps(other_max0 + j), _CMP_LE_OQ));
      hit = _mm256_and_ps(hit, _mm256_cmp_ps(_mm256_loadu_ps(other_min1 + j), max1, _CMP_LE_OQ));
      hit = _mm256_and_ps(hit, _mm256_cmp_ps(min1, _mm256_loadu_ps(other_max1 + j), _CMP_LE_OQ));
      if (const int hit_bits = _mm256_movemask_ps(hit); hit_bits != 0) {
        // Rarely reached, so the filters and the slab rule are tested here.
        const __m256i refused = _mm256_or_si256(
            _mm256_cmpeq_epi32(
                _mm256_and_si256(_mm256_set1_epi32(a.group), loadInts(their_masks + j)), zero),
            _mm256_cmpeq_epi32(
                _mm256_and_si256(loadInts(their_groups + j), _mm256_set1_epi32(a.mask)), zero));
        const __m256i first_shared =
            _mm256_or_si256(_mm256_set1_epi32(a.starts_here), loadInts(their_starts + j));
        const int kept =
            hit_bits &
            _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_andnot_si256(refused, first_shared)));
        if (kept != 0) {
          appendKeys(_mm256_set1_epi32(static_cast<std::int32_t>(a.slot)), loadInts(slots + j),
                     kept, pairs);
        }
      }
      if (inside_bits != 0xFF) break;
    }
  }
}

#endif

}  // namespace

bool avx2Available() {
#if OVERLAP_HAVE_AVX2_KERNEL
  return __builtin_cpu_supports("avx2") != 0;
#else
  return false;
#endif
}

void SweepLayout::plan(std::span<const ObjectBounds> objects, std::span<const std::uint64_t> sorted,
                       int sweep_axis, int slab_axis, const SlabGrid& grid) {
  objects_ = objects;
  axes_ = {sweep_axis, slab_axis, 3 - sweep_axis - slab_axis};
  // Each slab's size, then where it starts: its boxes, then kLanes of padding.
  first_slab_.resize(sorted.size());
  last_slab_.resize(sorted.size());
  slab_starts_.assign(std::size_t{grid.count} + 1, 0);
  for (std::size_t k = 0; k < sorted.size(); ++k) {
    const ObjectBounds& box = objects[static_cast<std::uint32_t>(sorted[k])];
    first_slab_[k] = grid.slabOf(box.min[slab_axis]);
    last_slab_[k] = grid.slabOf(box.max[slab_axis]);
    for (std::uint32_t slab = first_slab_[k]; slab <= last_slab_[k]; ++slab) {
      ++slab_starts_[slab + 1];
    }
  }
  for (std::uint32_t slab = 0; slab < grid.count; ++slab) {
    slab_starts_[slab + 1] += slab_starts_[slab] + kLanes;
  }
  const std::uint32_t size = slab_starts_.back();
  for (auto* column :
       {&sweep_min_, &sweep_max_, &other_min_[0], &other_max_[0], &other_min_[1], &other_max_[1]}) {
    column->resize(size);
  }
  for (auto* column : {&group_, &mask_, &starts_here_}) column->resize(size);
  slot_.resize(size);

  // The boxes in sweep order into each slab they reach, so every slab stays
  // sorted; only the slot here, gather() copies the boxes.
  slab_cursor_.assign(slab_starts_.begin(), slab_starts_.end() - 1);
  for (std::size_t k = 0; k < sorted.size(); ++k) {
    for (std::uint32_t slab = first_slab_[k]; slab <= last_slab_[k]; ++slab) {
      const std::uint32_t i = slab_cursor_[slab]++;
      slot_[i] = static_cast<std::uint32_t>(sorted[k]);
      starts_here_[i] = slab == first_slab_[k] ? -1 : 0;
    }
  }
  for (std::uint32_t slab = 0; slab < grid.count; ++slab) {
    for (std::uint32_t i = slab_cursor_[slab]; i < slab_starts_[slab + 1]; ++i) {
      slot_[i] = kPaddingSlot;
      starts_here_[i] = 0;
    }
  }
}

void SweepLayout::gather(std::uint32_t first, std::uint32_t end) {
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  const auto [sweep_axis, slab_axis, third_axis] = axes_;
  for (std::uint32_t i = first; i < end; ++i) {
    if (slot_[i] == kPaddingSlot) {
      sweep_min_[i] = sweep_max_[i] = kNaN;  // ends every scan; starts none
      other_min_[0][i] = other_max_[0][i] = other_min_[1][i] = other_max_[1][i] = kNaN;
      group_[i] = mask_[i] = 0;
      continue;
    }
    const ObjectBounds& box = objects_[slot_[i]];
    sweep_min_[i] = box.min[sweep_axis];
    sweep_max_[i] = box.max[sweep_axis];
    other_min_[0][i] = box.min[slab_axis];
    other_max_[0][i] = box.max[slab_axis];
    other_min_[1][i] = box.min[third_axis];
    other_max_[1][i] = box.max[third_axis];
    group_[i] = box.group;
    mask_[i] = box.mask;
  }
}

void SweepLayout::indexForQueries() {
  reach_.resize(size());
  for (std::size_t slab = 0; slab + 1 < slab_starts_.size(); ++slab) {
    float reach = -std::numeric_limits<float>::infinity();
    for (std::uint32_t i = slab_starts_[slab]; i < slab_starts_[slab + 1]; ++i) {
      if (slot_[i] != kPaddingSlot) reach = std::max(reach, sweep_max_[i]);
      reach_[i] = reach;
    }
  }
}

void SweepLayout::query(const ObjectBounds& box, const SlabGrid& grid,
                        std::vector<std::uint32_t>& hits) const {
  const auto [sweep_axis, slab_axis, third_axis] = axes_;
  const std::uint32_t first_slab = grid.slabOf(box.min[slab_axis]);
  const std::uint32_t last_slab = grid.slabOf(box.max[slab_axis]);
  for (std::uint32_t slab = first_slab; slab <= last_slab && slab + 1 < slab_starts_.size();
       ++slab) {
    // The boxes before the first whose slab reach gets to `box` all end
    // before it starts: the scan begins there and ends past `box`'s max.
    const std::uint32_t slab_end = slab_starts_[slab + 1] - kLanes;
    const auto first = static_cast<std::uint32_t>(
        std::lower_bound(reach_.begin() + slab_starts_[slab], reach_.begin() + slab_end,
                         box.min[sweep_axis]) -
        reach_.begin());
    for (std::uint32_t k = first; k < slab_end && sweep_min_[k] <= box.max[sweep_axis]; ++k) {
      const bool pairs_with = (box.min[sweep_axis] <= sweep_max_[k]) &
                              pair_logic::intervalsOverlap(box.min[slab_axis], box.max[slab_axis],
                                                           other_min_[0][k], other_max_[0][k]) &
                              pair_logic::intervalsOverlap(box.min[third_axis], box.max[third_axis],
                                                           other_min_[1][k], other_max_[1][k]) &
                              pair_logic::filtersAccept(box.group, box.mask, group_[k], mask_[k]) &
                              ((slab == first_slab) | (starts_here_[k] != 0));
      if (pairs_with) hits.push_back(slot_[k]);
    }
  }
}

void SweepLayout::cutChunks(std::size_t chunks, std::vector<std::uint32_t>& starts) const {
  const auto work = [&](std::uint32_t i, double fixed) {
    const float extent = sweep_max_[i] - sweep_min_[i];  // NaN for padding
    return std::isfinite(extent) ? extent + fixed : 0.0;
  };
  double total = 0;
  for (std::uint32_t i = 0; i < size(); ++i) total += work(i, 0);
  const double fixed = size() == 0 ? 0 : 0.25 * total / size();
  const double step =
      (total + fixed * size()) / static_cast<double>(std::max<std::size_t>(chunks, 1));
  starts.assign(1, 0);
  double done = 0;
  for (std::uint32_t i = 0; i < size() && starts.size() < chunks; ++i) {
    done += work(i, fixed);
    if (done >= step * static_cast<double>(starts.size())) starts.push_back(i + 1);
  }
  if (starts.back() != size()) starts.push_back(size());
}

void SweepLayout::sweep(SweepKernel kernel, std::uint32_t first, std::uint32_t end,
                        PairKeys& pairs) const {
  // The last slab's padding starts no scan: the kernels read kLanes entries
  // past the one they scan from, which must exist.
  end = std::min(end, size() - kLanes);
  const Columns columns{sweep_min_.data(),
                        sweep_max_.data(),
                        {other_min_[0].data(), other_min_[1].data()},
                        {other_max_[0].data(), other_max_[1].data()},
                        group_.data(),
                        mask_.data(),
                        starts_here_.data(),
                        slot_.data()};
  switch (kernel) {
    case SweepKernel::kScalar:
      sweepScalar(columns, first, end, pairs);
      return;
    case SweepKernel::kAvx2:
#if OVERLAP_HAVE_AVX2_KERNEL
      sweepAvx2(columns, first, end, pairs);
      return;
#else
      break;
#endif
    case SweepKernel::kFastest:
      break;
  }
  throw std::logic_error("SweepLayout::sweep: no such kernel here; resolve kFastest first");
}

}  // namespace overlap::finders::sap
