// Axis-aligned boxes and pair lists as the world, the recorded streams and
// the replays hand them around: plain values, free of Bullet, so a module
// that reads AABBs or pairs needs no part of the Bullet adapter.
//
// Invariants: a PairList names each pair once, as (a, b) with a < b, sorted;
// orderedPair() is the one place a pair is put in that order.
#pragma once

#include <cstdint>
#include <vector>

#include "gpu/pairs/pair_types.h"

namespace overlap::physics {

struct Aabb {
  float min[3];
  float max[3];
};

// Object-index pairs (a < b), sorted: the world's cached pairs, a replay's.
using PairList = std::vector<finders::IndexPair>;

// The pair of two object indices (>= 0) given in either order.
inline finders::IndexPair orderedPair(int x, int y) {
  return {static_cast<std::uint32_t>(x < y ? x : y), static_cast<std::uint32_t>(x < y ? y : x)};
}

}  // namespace overlap::physics
