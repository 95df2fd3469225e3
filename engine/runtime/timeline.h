// The frame timeline: named spans on named lanes (main thread, tasks,
// sound, AI), each tagged with its frame and, for a substep's spans
// (substep, broadphase, narrowphase), its substep; written
// in the Chrome trace event format, which Perfetto (ui.perfetto.dev) and
// chrome://tracing open.  Spans are kept as points on the steady clock and
// written as microseconds since the run started.
#pragma once

#include <chrono>
#include <string>
#include <vector>

namespace overlap::engine {

using Clock = std::chrono::steady_clock;

// A job's run: when it started and when it ended.
struct Interval {
  Clock::time_point start;
  Clock::time_point end;
  Clock::duration length() const { return end - start; }
};

// How long `a` and `b` ran at the same time.
Clock::duration overlapOf(const Interval& a, const Interval& b);

struct Span {
  std::string name;
  std::string lane;
  Interval at;
  int frame;
  int substep = -1;  // the physics substep it belongs to; -1: the whole frame's
};

class Timeline {
 public:
  explicit Timeline(Clock::time_point origin = Clock::now()) : origin_(origin) {}
  void add(Span span) { spans_.push_back(std::move(span)); }
  const std::vector<Span>& spans() const { return spans_; }
  // The whole run as one JSON trace (timeline.json's contents).
  std::string json() const;

 private:
  Clock::time_point origin_;
  std::vector<Span> spans_;
};

}  // namespace overlap::engine
