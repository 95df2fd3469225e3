// Mean, median and percentiles of a column of measurements.  The median is
// what benchmarks quote (one slow frame from the OS should not move it); the
// 95th and 99th percentiles and the maximum are what a game developer judges
// a frame by (one slow frame in twenty is a stutter the median hides).
// Rules, each with its reason:
// - An empty column gives 0 everywhere: a run of no frames has nothing to
//   show, and the callers print and write what they get without a branch.
// - A percentile interpolates linearly between the two nearest order
//   statistics (numpy's default), so percentile(v, 0.5) == median(v) and
//   percentile(v, 1) is the maximum.
#pragma once

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

namespace overlap::engine {

inline double mean(const std::vector<double>& values) {
  if (values.empty()) return 0.0;
  return std::accumulate(values.begin(), values.end(), 0.0) / static_cast<double>(values.size());
}

// `share` in [0, 1]: 0.95 is the 95th percentile.
inline double percentile(std::vector<double> values, double share) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double rank = std::clamp(share, 0.0, 1.0) * static_cast<double>(values.size() - 1);
  const auto below = static_cast<std::size_t>(std::floor(rank));
  const std::size_t above = std::min(below + 1, values.size() - 1);
  return values[below] + (values[above] - values[below]) * (rank - static_cast<double>(below));
}

inline double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  if (values.size() % 2 == 1) return *middle;
  return (*middle + *std::max_element(values.begin(), middle)) / 2.0;
}

}  // namespace overlap::engine
