// UniformGrid: buckets points into the cells of a cube so that "which points
// are near here?" visits a few cells instead of every point.
//
// rebuild() sorts the points by cell with a counting sort (two passes, no
// allocation once the buffers have grown); points outside the cube fall into
// its border cells, so none is ever lost.  forEachNear() visits every point
// whose cell meets the axis-aligned cube of half-size `reach` around a centre,
// in cell order then index order, so a query's visiting order is
// deterministic; callers test the exact distance themselves.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

namespace overlap::stubs {

class UniformGrid {
 public:
  // Covers [-half_extent, half_extent]^3 with cubic cells about `cell_size`
  // wide, coarsened if needed so that no axis has more than kMaxCellsPerAxis.
  void rebuild(std::span<const Eigen::Vector3f> points, float half_extent, float cell_size);

  template <typename Visit>
  void forEachNear(const Eigen::Vector3f& centre, float reach, Visit&& visit) const {
    const Eigen::Vector3i lo = cellOf(centre.array() - reach);
    const Eigen::Vector3i hi = cellOf(centre.array() + reach);
    for (int z = lo.z(); z <= hi.z(); ++z) {
      for (int y = lo.y(); y <= hi.y(); ++y) {
        const int row = (z * cells_per_axis_ + y) * cells_per_axis_;
        const std::uint32_t begin = cell_start_[static_cast<std::size_t>(row + lo.x())];
        const std::uint32_t end = cell_start_[static_cast<std::size_t>(row + hi.x() + 1)];
        for (std::uint32_t i = begin; i < end; ++i) visit(sorted_[i]);
      }
    }
  }

  static constexpr int kMaxCellsPerAxis = 64;

 private:
  Eigen::Vector3i cellOf(const Eigen::Vector3f& point) const {
    const Eigen::Array3f scaled = (point.array() + half_extent_) * inverse_cell_size_;
    return scaled.floor()
        .max(0.0f)
        .min(static_cast<float>(cells_per_axis_ - 1))
        .cast<int>()
        .matrix();
  }

  float half_extent_ = 0.0f;
  float inverse_cell_size_ = 1.0f;
  int cells_per_axis_ = 1;
  // Points of cell c are sorted_[cell_start_[c] .. cell_start_[c + 1]); cells
  // are numbered x fastest, so a row of cells is one contiguous range.
  std::vector<std::uint32_t> cell_start_{0, 0};
  std::vector<std::uint32_t> sorted_;
  std::vector<std::uint32_t> cell_of_point_;  // rebuild()'s scratch
  std::vector<std::uint32_t> fill_cursor_;    // rebuild()'s scratch
};

}  // namespace overlap::stubs
