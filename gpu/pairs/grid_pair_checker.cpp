#include "gpu/pairs/grid_pair_checker.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "gpu/pairs/pair_logic.h"
#include "gpu/pairs/pair_set.h"

namespace overlap::finders {
namespace {

// Cells this many mean box extents wide.
constexpr double kCellInExtents = 2.0;
// A box reaching over more cells than this is tested one by one instead.
constexpr double kMostCellsPerBox = 512;
// Cell coordinates fit 21 bits each in a 64-bit key.
constexpr double kMostCellsPerAxis = (1 << 21) - 2;

struct Grid {
  double origin[3];
  double inverse_cell;

  std::int64_t cellOf(float v, int axis) const {
    return static_cast<std::int64_t>(std::floor((double{v} - origin[axis]) * inverse_cell));
  }
  static std::uint64_t key(std::int64_t x, std::int64_t y, std::int64_t z) {
    return (static_cast<std::uint64_t>(x) << 42) | (static_cast<std::uint64_t>(y) << 21) |
           static_cast<std::uint64_t>(z);
  }
};

// On the grid: ordered as a sweep needs it (pair_logic::boundsOrdered) and
// finite, so that it has cells.  Any other box is tested one by one.
bool placeable(const ObjectBounds& box) {
  bool finite = true;
  for (int axis = 0; axis < 3; ++axis) {
    finite &= std::isfinite(box.min[axis]) && std::isfinite(box.max[axis]);
  }
  return finite && pair_logic::boundsOrdered(box);
}

// The grid spans the placeable boxes; its cell is a few mean extents.
Grid gridOver(std::span<const ObjectBounds> objects) {
  double lowest[3] = {INFINITY, INFINITY, INFINITY}, highest[3] = {-INFINITY, -INFINITY, -INFINITY};
  double extents = 0;
  std::size_t placed = 0;
  for (const ObjectBounds& box : objects) {
    if (!placeable(box)) continue;
    ++placed;
    for (int axis = 0; axis < 3; ++axis) {
      lowest[axis] = std::min(lowest[axis], double{box.min[axis]});
      highest[axis] = std::max(highest[axis], double{box.max[axis]});
      extents += double{box.max[axis]} - double{box.min[axis]};
    }
  }
  double cell = placed > 0 ? kCellInExtents * extents / (3.0 * static_cast<double>(placed)) : 1;
  for (int axis = 0; axis < 3 && placed > 0; ++axis) {
    cell = std::max(cell, (highest[axis] - lowest[axis]) / kMostCellsPerAxis);
  }
  if (!(cell > 0) || !std::isfinite(cell)) cell = 1;
  return Grid{{lowest[0], lowest[1], lowest[2]}, 1.0 / cell};
}

}  // namespace

std::vector<std::uint64_t> gridCheckerPairs(std::span<const ObjectBounds> objects) {
  const auto count = static_cast<std::uint32_t>(objects.size());
  const Grid grid = gridOver(objects);

  std::vector<std::pair<std::uint64_t, std::uint32_t>> listed;  // (cell, box)
  std::vector<std::uint32_t> loose;                             // tested one by one
  listed.reserve(objects.size() * 2);
  for (std::uint32_t i = 0; i < count; ++i) {
    const ObjectBounds& box = objects[i];
    if (!placeable(box)) {
      loose.push_back(i);
      continue;
    }
    std::int64_t lo[3], hi[3];
    double cells = 1;
    for (int axis = 0; axis < 3; ++axis) {
      lo[axis] = grid.cellOf(box.min[axis], axis);
      hi[axis] = grid.cellOf(box.max[axis], axis);
      cells *= static_cast<double>(hi[axis] - lo[axis] + 1);
    }
    if (cells > kMostCellsPerBox) {
      loose.push_back(i);
      continue;
    }
    for (std::int64_t x = lo[0]; x <= hi[0]; ++x) {
      for (std::int64_t y = lo[1]; y <= hi[1]; ++y) {
        for (std::int64_t z = lo[2]; z <= hi[2]; ++z) listed.emplace_back(Grid::key(x, y, z), i);
      }
    }
  }
  std::sort(listed.begin(), listed.end());

  std::vector<std::uint64_t> pairs;
  for (std::size_t run = 0; run < listed.size();) {
    std::size_t end = run + 1;
    while (end < listed.size() && listed[end].first == listed[run].first) ++end;
    for (std::size_t p = run; p < end; ++p) {
      const ObjectBounds& a = objects[listed[p].second];
      for (std::size_t q = p + 1; q < end; ++q) {
        const ObjectBounds& b = objects[listed[q].second];
        if (!pair_logic::objectsPair(a, b)) continue;
        const std::uint64_t corner = Grid::key(grid.cellOf(std::max(a.min[0], b.min[0]), 0),
                                               grid.cellOf(std::max(a.min[1], b.min[1]), 1),
                                               grid.cellOf(std::max(a.min[2], b.min[2]), 2));
        if (corner == listed[run].first)
          pairs.push_back(pairKey(listed[p].second, listed[q].second));
      }
    }
    run = end;
  }
  // The loose boxes against every box; two loose boxes once.
  std::vector<std::uint8_t> is_loose(count, 0);
  for (const std::uint32_t i : loose) is_loose[i] = 1;
  for (const std::uint32_t i : loose) {
    for (std::uint32_t j = 0; j < count; ++j) {
      if (j == i || (is_loose[j] != 0 && j < i)) continue;
      if (pair_logic::objectsPair(objects[i], objects[j])) pairs.push_back(pairKey(i, j));
    }
  }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

}  // namespace overlap::finders
