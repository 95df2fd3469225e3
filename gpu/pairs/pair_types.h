// The pair value types every finder and the pair logic share: a slot's box
// and collision filter as the caller hands it over, a pair of slots, and a
// pair's 64-bit sort key.  Plain values, free of Bullet and of the finder
// interface (gpu/pair_finder.h, which includes this), so the shared pair
// logic (gpu/pairs/) needs nothing above it.
//
// Invariants: an IndexPair has a < b, and lists of them are sorted by (a, b);
// pairKey() sorts as the pairs do.
#pragma once

#include <compare>
#include <cstdint>

namespace overlap::finders {

// One slot's box and collision filter, as the caller hands it over.  32 bytes
// and 16-byte aligned so the GPU reads one object with two vector loads.
struct alignas(16) ObjectBounds {
  float min[3];
  float max[3];
  std::int32_t group;
  std::int32_t mask;
};

// Two slots (or objects, or bodies) that overlap: the project's one pair
// type.  Lists of them are sorted by (a, b).
struct IndexPair {
  std::uint32_t a;  // a < b
  std::uint32_t b;
  friend bool operator==(const IndexPair&, const IndexPair&) = default;
  friend auto operator<=>(const IndexPair&, const IndexPair&) = default;
};

// The IndexPair of slots x and y (in either order) as one 64-bit key, lower
// slot in the high half, so keys sort as the pairs do: the form a sweep
// collects pairs in (gpu/pairs/pair_set.h).
constexpr std::uint64_t pairKey(std::uint32_t x, std::uint32_t y) {
  const std::uint32_t a = x < y ? x : y;
  const std::uint32_t b = x < y ? y : x;
  return (std::uint64_t{a} << 32) | b;
}

}  // namespace overlap::finders
