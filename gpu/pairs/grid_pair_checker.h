// An exact answer for large n, to check cpusap where cpubf is too slow:
// every pair a < b whose boxes pair by gpu/pairs/pair_logic.h's rule (inclusive
// overlap, collision filters), found on a uniform grid with none of
// cpusap's code (no sort on an axis, no slabs, no sweep).
//
// Each box is listed in every grid cell its AABB reaches; two boxes listed
// in one cell are tested there, and a pair is kept only in the cell that
// holds the corner where their overlap starts (the largest of their mins on
// each axis), so it is found once.  Boxes the grid cannot place (a NaN, an
// inverted or infinite box, or one reaching over too many cells) are tested
// against every box, one by one.  Single-threaded, so that its answer is
// independent of the thread count.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "gpu/pairs/pair_types.h"

namespace overlap::finders {

// The pairs as pairKey()s (gpu/pairs/pair_set.h), sorted.
std::vector<std::uint64_t> gridCheckerPairs(std::span<const ObjectBounds> objects);

}  // namespace overlap::finders
