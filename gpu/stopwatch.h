// A wall-clock stopwatch on std::chrono::steady_clock, for the host-side
// timings the finders and the physics stages report.
#pragma once

#include <chrono>

namespace overlap::gpu {

class HostStopwatch {
 public:
  // Milliseconds since construction.
  double ms() const {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_)
        .count();
  }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace overlap::gpu
