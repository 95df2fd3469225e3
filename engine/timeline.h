// The frame timeline: named spans on named lanes (main thread, broadphase
// search, tasks, sound, AI), each tagged with its frame and, for a
// substep's spans (substep, search, join, narrowphase), its substep; written in the Chrome trace
// event format, which Perfetto (ui.perfetto.dev) and chrome://tracing open.  Times are microseconds
// since the run started.
#pragma once

#include <chrono>
#include <string>
#include <vector>

namespace overlap::engine {

// A span keeps its end, not its length: two jobs that end at one instant
// (the last task and the tasks' job, say) then end at the same number, which
// start + duration, rounded twice, would not promise.
struct Span {
  std::string name;
  std::string lane;
  double start_us;
  double end_us;
  int frame;
  int substep = -1;  // the physics substep it belongs to; -1: the whole frame's

  double durationUs() const { return end_us - start_us; }
};

class Timeline {
 public:
  using Clock = std::chrono::steady_clock;

  explicit Timeline(Clock::time_point origin = Clock::now()) : origin_(origin) {}
  double microsecondsAt(Clock::time_point t) const {
    return std::chrono::duration<double, std::micro>(t - origin_).count();
  }
  void add(Span span) { spans_.push_back(std::move(span)); }
  const std::vector<Span>& spans() const { return spans_; }
  // The whole run as one JSON trace (timeline.json's contents).
  std::string json() const;

 private:
  Clock::time_point origin_;
  std::vector<Span> spans_;
};

// The share of [start, start + duration) that lies inside any of `busy`
// (intervals in the same units, possibly overlapping each other).
double coveredShare(double start, double duration, std::vector<std::pair<double, double>> busy);

}  // namespace overlap::engine
