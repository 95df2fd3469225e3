#include "engine/runtime/run_summary.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <string_view>

#include "engine/runtime/statistics.h"

namespace overlap::engine {
namespace {

// "4.5%", "12%": a share of a whole, one decimal below 10%.
std::string percentText(double part, double whole) {
  const double percent = whole > 0 ? 100.0 * part / whole : 0.0;
  return fixedText(percent, percent < 9.95 ? 1 : 0) + "%";
}

bool readsAsNumber(std::string_view cell) {
  // "-" stands for a number that is not there, in a column of numbers.
  return !cell.empty() &&
         (std::isdigit(static_cast<unsigned char>(cell.front())) != 0 || cell.front() == '-');
}

}  // namespace

std::string fixedText(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}

std::string threeDigits(double value) {
  const double size = std::fabs(value);
  const int magnitude = size > 0 ? static_cast<int>(std::floor(std::log10(size))) : 0;
  return fixedText(value, std::clamp(2 - magnitude, 0, 3));
}

FrameSpread spreadOf(const std::vector<double>& values) {
  if (values.empty()) return {};
  return {median(values), percentile(values, 0.95), percentile(values, 0.99),
          *std::max_element(values.begin(), values.end())};
}

int countOver(const std::vector<double>& values, double limit) {
  return static_cast<int>(
      std::count_if(values.begin(), values.end(), [limit](double value) { return value > limit; }));
}

Speedup speedupOf(const std::vector<double>& sync_ms, const std::vector<double>& async_ms) {
  std::vector<double> ratios;
  for (std::size_t i = 0; i < std::min(sync_ms.size(), async_ms.size()); ++i) {
    if (async_ms[i] > 0) ratios.push_back(sync_ms[i] / async_ms[i]);
  }
  const double async_median = median(async_ms);
  return {async_median > 0 ? median(sync_ms) / async_median : 0.0, percentile(ratios, 0.25),
          percentile(ratios, 0.5), percentile(ratios, 0.75)};
}

void FrameSummary::add(double frame_ms, const physics::FrameTimings& physics) {
  frame_ms_.push_back(frame_ms);
  stages_.push_back(physics);
}

std::vector<std::string> FrameSummary::lines() const {
  const FrameSpread spread = frameSpread();
  const auto meanOf = [this](double physics::FrameTimings::*stage) {
    double sum = 0;
    for (const physics::FrameTimings& frame : stages_) sum += frame.*stage;
    return stages_.empty() ? 0.0 : sum / static_cast<double>(stages_.size());
  };
  const double frame = mean(frame_ms_);
  const double step = meanOf(&physics::FrameTimings::total_ms);
  std::string split;
  double named = 0;
  for (const auto& [name, stage] : {std::pair{"update", &physics::FrameTimings::update_ms},
                                    {"broadphase", &physics::FrameTimings::broadphase_ms},
                                    {"narrowphase", &physics::FrameTimings::narrowphase_ms},
                                    {"solver", &physics::FrameTimings::solver_ms},
                                    {"integrate", &physics::FrameTimings::integrate_ms},
                                    {"ccd query", &physics::FrameTimings::ccd_query_ms}}) {
    const double ms = meanOf(stage);
    named += ms;
    split += std::string(split.empty() ? "" : ", ") + name + " " + threeDigits(ms) + " (" +
             percentText(ms, step) + ")";
  }
  const double other = std::max(0.0, step - named);
  split += ", other " + threeDigits(other) + " (" + percentText(other, step) + ")";
  const double broadphase = meanOf(&physics::FrameTimings::broadphase_ms);
  const double with_update = broadphase + meanOf(&physics::FrameTimings::update_ms);
  return {"frame       median " + threeDigits(spread.median) + " ms, p95 " +
              threeDigits(spread.p95) + ", p99 " + threeDigits(spread.p99) + ", max " +
              threeDigits(spread.max) + "; " + std::to_string(framesOverFrameTime()) + " of " +
              std::to_string(frames()) + " over the frame time (" + threeDigits(frame_time_ms_) +
              " ms)",
          "physics     " + threeDigits(step) + " ms a frame (means): " + split,
          "broadphase  " + threeDigits(broadphase) + " ms of the mean frame's " +
              threeDigits(frame) + " (" + percentText(broadphase, frame) + "); with the update " +
              threeDigits(with_update) + " ms (" + percentText(with_update, frame) + ")"};
}

std::vector<std::string> alignedTable(const std::vector<std::vector<std::string>>& rows) {
  std::vector<std::size_t> widths;
  std::vector<bool> numeric;  // a column whose cells below the header all read as numbers
  for (std::size_t r = 0; r < rows.size(); ++r) {
    widths.resize(std::max(widths.size(), rows[r].size()), 0);
    numeric.resize(widths.size(), rows.size() > 1);
    for (std::size_t column = 0; column < rows[r].size(); ++column) {
      widths[column] = std::max(widths[column], rows[r][column].size());
      if (r > 0 && !readsAsNumber(rows[r][column])) numeric[column] = false;
    }
  }
  std::vector<std::string> lines;
  for (const std::vector<std::string>& row : rows) {
    std::string line;
    for (std::size_t column = 0; column < row.size(); ++column) {
      const std::string& cell = row[column];
      const std::string pad(widths[column] - cell.size(), ' ');
      if (column > 0) line += "  ";
      line += numeric[column] ? pad + cell : cell + (column + 1 < row.size() ? pad : "");
    }
    lines.push_back(line);
  }
  return lines;
}

}  // namespace overlap::engine
