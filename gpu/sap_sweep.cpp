#include "gpu/sap_sweep.h"

#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "gpu/pair_logic.h"
#include "gpu/pair_set.h"

#if defined(__x86_64__)
#include <immintrin.h>
#define OVERLAP_HAVE_AVX2_KERNEL 1
#else
#define OVERLAP_HAVE_AVX2_KERNEL 0
#endif

namespace overlap::gpu::sap {
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

void sweepScalar(const Columns& c, std::uint32_t first, std::uint32_t end,
                 std::vector<std::uint64_t>& pairs) {
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

__attribute__((target("avx2"))) __m256 loadFloats(const float* p) {
  return _mm256_loadu_ps(p);
}

__attribute__((target("avx2"))) __m256i loadInts(const std::int32_t* p) {
  return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
}

// The scalar kernel's tests on eight candidates j .. j + 7 at once.  The
// comparisons are ordered and non-signalling (_CMP_LE_OQ): false on NaN, as
// the scalar '<=' is.
__attribute__((target("avx2"))) void sweepAvx2(const Columns& c, std::uint32_t first,
                                               std::uint32_t end,
                                               std::vector<std::uint64_t>& pairs) {
  const __m256i zero = _mm256_setzero_si256();
  for (std::uint32_t i = first; i < end; ++i) {
    const Scanner a(c, i);
    const __m256 sweep_max = _mm256_set1_ps(a.sweep_max);
    const __m256 min0 = _mm256_set1_ps(a.other_min[0]), max0 = _mm256_set1_ps(a.other_max[0]);
    const __m256 min1 = _mm256_set1_ps(a.other_min[1]), max1 = _mm256_set1_ps(a.other_max[1]);
    const __m256i group = _mm256_set1_epi32(a.group), mask = _mm256_set1_epi32(a.mask);
    const __m256i starts_here = _mm256_set1_epi32(a.starts_here);
    for (std::uint32_t j = i + 1;; j += kLanes) {
      // Sorted order makes the candidates inside i's extent a prefix of the
      // eight lanes; the scan goes on only while all eight are inside.
      const __m256 inside = _mm256_cmp_ps(loadFloats(c.sweep_min + j), sweep_max, _CMP_LE_OQ);
      const int inside_bits = _mm256_movemask_ps(inside);
      if (inside_bits == 0) break;
      __m256 hit =
          _mm256_and_ps(inside, _mm256_cmp_ps(loadFloats(c.other_min[0] + j), max0, _CMP_LE_OQ));
      hit = _mm256_and_ps(hit, _mm256_cmp_ps(min0, loadFloats(c.other_max[0] + j), _CMP_LE_OQ));
      hit = _mm256_and_ps(hit, _mm256_cmp_ps(loadFloats(c.other_min[1] + j), max1, _CMP_LE_OQ));
      hit = _mm256_and_ps(hit, _mm256_cmp_ps(min1, loadFloats(c.other_max[1] + j), _CMP_LE_OQ));
      int hit_bits = _mm256_movemask_ps(hit);
      if (hit_bits != 0) {
        // Rarely reached, so the filters and the slab rule are tested here.
        const __m256i their_group = loadInts(c.group + j);
        const __m256i their_mask = loadInts(c.mask + j);
        const __m256i refused =
            _mm256_or_si256(_mm256_cmpeq_epi32(_mm256_and_si256(group, their_mask), zero),
                            _mm256_cmpeq_epi32(_mm256_and_si256(their_group, mask), zero));
        const __m256i first_shared = _mm256_or_si256(starts_here, loadInts(c.starts_here + j));
        hit_bits &=
            _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_andnot_si256(refused, first_shared)));
        for (; hit_bits != 0; hit_bits &= hit_bits - 1) {
          const int lane = std::countr_zero(static_cast<unsigned>(hit_bits));
          pairs.push_back(pairKey(a.slot, c.slot[j + static_cast<std::uint32_t>(lane)]));
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

void SweepLayout::layOut(std::span<const ObjectBounds> objects,
                         std::span<const std::uint64_t> sorted, int sweep_axis, int slab_axis,
                         const SlabGrid& grid) {
  const int third_axis = 3 - sweep_axis - slab_axis;
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

  // The boxes in sweep order into each slab they reach: every slab stays sorted.
  slab_cursor_.assign(slab_starts_.begin(), slab_starts_.end() - 1);
  for (std::size_t k = 0; k < sorted.size(); ++k) {
    const auto slot = static_cast<std::uint32_t>(sorted[k]);
    const ObjectBounds& box = objects[slot];
    for (std::uint32_t slab = first_slab_[k]; slab <= last_slab_[k]; ++slab) {
      const std::uint32_t i = slab_cursor_[slab]++;
      sweep_min_[i] = box.min[sweep_axis];
      sweep_max_[i] = box.max[sweep_axis];
      other_min_[0][i] = box.min[slab_axis];
      other_max_[0][i] = box.max[slab_axis];
      other_min_[1][i] = box.min[third_axis];
      other_max_[1][i] = box.max[third_axis];
      group_[i] = box.group;
      mask_[i] = box.mask;
      starts_here_[i] = slab == first_slab_[k] ? -1 : 0;
      slot_[i] = slot;
    }
  }
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  for (std::uint32_t slab = 0; slab < grid.count; ++slab) {
    for (std::uint32_t i = slab_cursor_[slab]; i < slab_starts_[slab + 1]; ++i) {
      sweep_min_[i] = sweep_max_[i] = kNaN;  // ends every scan; starts none
      other_min_[0][i] = other_max_[0][i] = other_min_[1][i] = other_max_[1][i] = kNaN;
      group_[i] = mask_[i] = starts_here_[i] = 0;
      slot_[i] = 0;
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
                        std::vector<std::uint64_t>& pairs) const {
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

}  // namespace overlap::gpu::sap
