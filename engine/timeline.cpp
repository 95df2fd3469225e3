#include "engine/timeline.h"

#include <algorithm>
#include <map>
#include <nlohmann/json.hpp>

namespace overlap::engine {

std::string Timeline::json() const {
  // Lanes become threads of one process, numbered in order of appearance.
  std::map<std::string, int> lane_ids;
  nlohmann::json events = nlohmann::json::array();
  for (const Span& span : spans_) {
    const auto [it, added] = lane_ids.emplace(span.lane, static_cast<int>(lane_ids.size()) + 1);
    if (added) {
      events.push_back({{"name", "thread_name"},
                        {"ph", "M"},
                        {"pid", 1},
                        {"tid", it->second},
                        {"args", {{"name", span.lane}}}});
    }
    nlohmann::json args = {{"frame", span.frame}};
    if (span.substep >= 0) args["substep"] = span.substep;
    events.push_back({{"name", span.name},
                      {"ph", "X"},
                      {"pid", 1},
                      {"tid", it->second},
                      {"ts", span.start_us},
                      {"dur", span.durationUs()},
                      {"args", args}});
  }
  const nlohmann::json trace = {{"traceEvents", events}, {"displayTimeUnit", "ms"}};
  return trace.dump();
}

double coveredShare(double start, double duration, std::vector<std::pair<double, double>> busy) {
  if (duration <= 0) return 0.0;
  const double end = start + duration;
  std::sort(busy.begin(), busy.end());
  double covered = 0.0;
  double reached = start;  // everything before this is counted already
  for (const auto& [from, to] : busy) {
    const double lo = std::max(from, reached);
    const double hi = std::min(to, end);
    if (hi > lo) {
      covered += hi - lo;
      reached = hi;
    }
  }
  return covered / duration;
}

}  // namespace overlap::engine
