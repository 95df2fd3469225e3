#include "engine/runtime/timeline.h"

#include <algorithm>
#include <map>
#include <nlohmann/json.hpp>

namespace overlap::engine {
namespace {

double microseconds(Clock::duration duration) {
  return std::chrono::duration<double, std::micro>(duration).count();
}

}  // namespace

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
                      {"ts", microseconds(span.at.start - origin_)},
                      {"dur", microseconds(span.at.length())},
                      {"args", args}});
  }
  const nlohmann::json trace = {{"traceEvents", events}, {"displayTimeUnit", "ms"}};
  return trace.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

Clock::duration overlapOf(const Interval& a, const Interval& b) {
  const Clock::time_point start = std::max(a.start, b.start);
  const Clock::time_point end = std::min(a.end, b.end);
  return end > start ? end - start : Clock::duration::zero();
}

}  // namespace overlap::engine
