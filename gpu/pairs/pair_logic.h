// Pair logic: the per-pair rules every pair finder applies, one source compiled
// for the CPU and, under nvcc, for the GPU.  What is shared is these functions
// (the pair numbering and its inverse, the AABB and filter tests, the XOR
// split), which cpubf calls in a loop of its own; the kernels' own code (warp
// ballots and shuffles, atomics, grid-stride loops, the host code around them)
// is not cpubf's.  That code runs on the CPU in the CUDA emulation build
// (gpu/emulation/), which executes the .cu files themselves; it cannot show
// timing, memory ordering and races between the threads of a block (they run
// one at a time), or what the real driver does.
//
// Pair numbering is triangular and independent of the slot count n:
//   p(a, b) = b (b - 1) / 2 + a   for a < b,
// so row b holds the b pairs (0, b) .. (b - 1, b) and growing n only appends
// pairs: an index, and every bit stored under it, stays valid.  Pair p lives in
// 32-bit word p / 32, bit p % 32 (cpubf's words, gpubf-paper's bytes; gpubf
// starts each row on a word of its own: gpu/pairs/row_words.h).  All index math is
// 64-bit and exact for every slot index below 2^32 (p below 2^63).
//
// Overlap is inclusive on all three axes (touching boxes pair, as in
// btSimpleBroadphase); a NaN coordinate compares false and so never pairs.
// The tests combine with '&' rather than '&&' so that they stay branch-free:
// the CPU loop vectorizes and a GPU warp does not diverge.
#pragma once

#include <math.h>  // ::sqrtf, which names the same function in host and device code

#include <cstdint>

#include "gpu/pairs/pair_types.h"

#if defined(__CUDACC__)
#define OVERLAP_HD __host__ __device__
#else
#define OVERLAP_HD
#endif

namespace overlap::finders::pair_logic {

inline constexpr std::uint32_t kBitsPerWord = 32;

// Number of pairs among slots 0..b-1, which is also p(0, b).  Halving the even
// factor first keeps it exact for every b <= 2^32.
OVERLAP_HD constexpr std::uint64_t pairsBelow(std::uint64_t b) {
  return b == 0 ? 0 : (b % 2 == 0 ? (b / 2) * (b - 1) : b * ((b - 1) / 2));
}

OVERLAP_HD constexpr std::uint64_t pairIndex(std::uint32_t a, std::uint32_t b) {
  return pairsBelow(b) + a;
}

// The row b of pair p (the largest b with pairsBelow(b) <= p) to within one,
// in FP32 and integer arithmetic only: consumer GPUs run FP64 at 1/32 to 1/64
// of the FP32 rate.  The FP32 square root of 2p is off by up to ~2^-23 of b
// (hundreds of rows near b = 2^32); one Newton step on the exact integer
// residual p - pairsBelow(b), rounded, takes it to at most one row (checked at
// row boundaries across the whole range in tests/gpu/pair_logic_test.cpp).
OVERLAP_HD inline std::uint64_t rowEstimate(std::uint64_t p) {
  constexpr std::int64_t kLargestSlot = 0xFFFFFFFFll;
  const auto clamp = [](std::int64_t b) {
    return static_cast<std::uint64_t>(b < 1 ? 1 : (b > kLargestSlot ? kLargestSlot : b));
  };
  const std::uint64_t first =
      clamp(static_cast<std::int64_t>(::sqrtf(2.0f * static_cast<float>(p)) + 0.5f));
  // Two's complement makes the difference right when pairsBelow(first) > p.
  const auto residual = static_cast<std::int64_t>(p - pairsBelow(first));
  const float step = static_cast<float>(residual) / (static_cast<float>(first) - 0.5f);
  return clamp(static_cast<std::int64_t>(first) + static_cast<std::int64_t>(::rintf(step)));
}

// Inverse of pairIndex, exact for every p below pairsBelow(2^32): the integer
// steps settle the estimate's last row whatever it is.
OVERLAP_HD inline IndexPair pairAt(std::uint64_t p) {
  constexpr std::uint64_t kLargestSlot = 0xFFFFFFFFull;
  std::uint64_t b = rowEstimate(p);
  while (b > 1 && pairsBelow(b) > p) --b;
  while (b < kLargestSlot && pairsBelow(b + 1) <= p) ++b;
  return IndexPair{static_cast<std::uint32_t>(p - pairsBelow(b)), static_cast<std::uint32_t>(b)};
}

OVERLAP_HD constexpr std::uint64_t wordCount(std::uint64_t pairs) {
  return (pairs + kBitsPerWord - 1) / kBitsPerWord;
}

OVERLAP_HD constexpr bool intervalsOverlap(float min_a, float max_a, float min_b, float max_b) {
  return (min_a <= max_b) & (min_b <= max_a);
}

OVERLAP_HD constexpr bool filtersAccept(std::int32_t group_a, std::int32_t mask_a,
                                        std::int32_t group_b, std::int32_t mask_b) {
  return ((group_a & mask_b) != 0) & ((group_b & mask_a) != 0);
}

OVERLAP_HD constexpr bool boxesOverlap(const ObjectBounds& x, const ObjectBounds& y) {
  return intervalsOverlap(x.min[0], x.max[0], y.min[0], y.max[0]) &
         intervalsOverlap(x.min[1], x.max[1], y.min[1], y.max[1]) &
         intervalsOverlap(x.min[2], x.max[2], y.min[2], y.max[2]);
}

// The whole rule for one pair: overlapping boxes whose filters accept each other.
OVERLAP_HD constexpr bool objectsPair(const ObjectBounds& x, const ObjectBounds& y) {
  return boxesOverlap(x, y) & filtersAccept(x.group, x.mask, y.group, y.mask);
}

// Whether a box can be placed by a sweep: min <= max on every axis (a NaN
// coordinate fails the test).  Bullet's AABBs always are; a box that is not
// is an error where it comes from Bullet (physics/broadphase/pair_finder_broadphase.h).
OVERLAP_HD constexpr bool boundsOrdered(const ObjectBounds& box) {
  return (box.min[0] <= box.max[0]) & (box.min[1] <= box.max[1]) & (box.min[2] <= box.max[2]);
}

OVERLAP_HD constexpr bool hasNaN(const ObjectBounds& box) {
  bool nan = false;
  for (int axis = 0; axis < 3; ++axis)
    nan |= (box.min[axis] != box.min[axis]) | (box.max[axis] != box.max[axis]);
  return nan;
}

// How a search entry takes part in objectsPair's rule, the one answer to
// "is this box usable?" for every finder that treats boxes apart:
// - kNone: pairs with nothing (a filter is zero: an unused slot; or a
//   coordinate is NaN, which fails every comparison);
// - kInverted: min > max on some axis, no NaN: it still pairs where
//   objectsPair says so, but a sweep cannot place it;
// - kOrdered: what a sweep sorts.
enum class BoxUse : std::uint8_t { kNone, kInverted, kOrdered };

OVERLAP_HD constexpr BoxUse boxUse(const ObjectBounds& box) {
  if ((box.group == 0) | (box.mask == 0) | hasNaN(box)) return BoxUse::kNone;
  return boundsOrdered(box) ? BoxUse::kOrdered : BoxUse::kInverted;
}

// Given one word of last frame's bits and the same word of this frame's.
OVERLAP_HD constexpr std::uint32_t addedBits(std::uint32_t previous, std::uint32_t current) {
  return (previous ^ current) & current;
}

OVERLAP_HD constexpr std::uint32_t removedBits(std::uint32_t previous, std::uint32_t current) {
  return (previous ^ current) & ~current;
}

}  // namespace overlap::finders::pair_logic
