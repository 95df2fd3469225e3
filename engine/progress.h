// Progress on stderr for long runs: silent for the first second, then at most
// one line a second with the frame, the elapsed time and an estimate of the
// time left, and a closing line.  Short runs print nothing.
#pragma once

#include <chrono>
#include <cstdio>
#include <string>

namespace overlap::engine {

class Progress {
 public:
  Progress(std::string label, int total) : label_(std::move(label)), total_(total) {}

  void update(int done) {
    const double elapsed = seconds();
    if (elapsed < next_report_) return;
    next_report_ = elapsed + 1.0;
    const double left = done > 0 ? elapsed * (total_ - done) / done : 0.0;
    std::fprintf(stderr, "%s: %d/%d frames, %.1f s elapsed, about %.0f s left\n", label_.c_str(),
                 done, total_, elapsed, left);
    reported_ = true;
  }

  void finish() {
    if (reported_) {
      std::fprintf(stderr, "%s: done, %d frames in %.1f s\n", label_.c_str(), total_, seconds());
    }
  }

  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  std::string label_;
  int total_;
  double next_report_ = 1.0;
  bool reported_ = false;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace overlap::engine
