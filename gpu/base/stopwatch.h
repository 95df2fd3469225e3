// Time on std::chrono::steady_clock: a stopwatch for the host-side timings
// every module reports (the finders, the physics phases, the engine), and the
// one conversion between the clock's durations and the milliseconds that
// reports print and the finders' own clocks give.
#pragma once

#include <chrono>

namespace overlap {

using SteadyClock = std::chrono::steady_clock;

inline double toMilliseconds(SteadyClock::duration duration) {
  return std::chrono::duration<double, std::milli>(duration).count();
}

class HostStopwatch {
 public:
  // Milliseconds since construction.
  double ms() const { return toMilliseconds(SteadyClock::now() - start_); }

 private:
  SteadyClock::time_point start_ = SteadyClock::now();
};

}  // namespace overlap
