#include "audio_ai_stubs/uniform_grid.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace overlap::stubs {

void UniformGrid::rebuild(std::span<const Eigen::Vector3f> points, float half_extent,
                          float cell_size) {
  if (!(half_extent > 0.0f) || !(cell_size > 0.0f)) {
    throw std::invalid_argument("UniformGrid: half_extent (" + std::to_string(half_extent) +
                                ") and cell_size (" + std::to_string(cell_size) +
                                ") must be positive");
  }
  half_extent_ = half_extent;
  cells_per_axis_ =
      std::clamp(static_cast<int>(std::ceil(2.0f * half_extent / cell_size)), 1, kMaxCellsPerAxis);
  inverse_cell_size_ = static_cast<float>(cells_per_axis_) / (2.0f * half_extent);

  const std::size_t cell_count = static_cast<std::size_t>(cells_per_axis_) *
                                 static_cast<std::size_t>(cells_per_axis_) *
                                 static_cast<std::size_t>(cells_per_axis_);
  cell_start_.assign(cell_count + 1, 0);
  cell_of_point_.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3i cell = cellOf(points[i]);
    const auto index = static_cast<std::uint32_t>(
        (cell.z() * cells_per_axis_ + cell.y()) * cells_per_axis_ + cell.x());
    cell_of_point_[i] = index;
    ++cell_start_[index + 1];
  }
  for (std::size_t c = 0; c < cell_count; ++c) cell_start_[c + 1] += cell_start_[c];

  sorted_.resize(points.size());
  fill_cursor_.assign(cell_start_.begin(), cell_start_.end() - 1);
  for (std::size_t i = 0; i < points.size(); ++i) {
    sorted_[fill_cursor_[cell_of_point_[i]]++] = static_cast<std::uint32_t>(i);
  }
}

}  // namespace overlap::stubs
