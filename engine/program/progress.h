// Progress on stderr for anything that can take more than two seconds:
// silent for the first second, then at most one line a second: the frames
// done, the time elapsed and the time left at the pace so far (the first
// line says how long the whole will take), or, for a step without frames
// (placing ten million boxes), the time elapsed.  A line is printed even
// while one long frame or step runs: a one-second interval timer (SIGALRM,
// SA_RESTART) prints it from its handler, so no thread is added beyond the
// --threads the run may use.  finish() closes with one line if any was
// printed; short runs print nothing.  One Progress reports at a time (a
// newer one pauses the older until it finishes).
#pragma once

#include <atomic>
#include <ctime>
#include <string>

namespace overlap::engine {

class Progress {
 public:
  // `total` frames to do; 0 for a step reported by its elapsed time only.
  Progress(std::string label, int total);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void update(int done) { done_.store(done, std::memory_order_relaxed); }
  void finish();
  double seconds() const;

  // The timer's work: one line; async-signal-safe.
  void report();

 private:
  std::string label_;
  int total_;
  std::atomic<int> done_{0};
  std::atomic<int> lines_{0};
  timespec start_{};
  Progress* paused_ = nullptr;  // the one this replaced, resumed by finish()
  bool finished_ = false;
};

// "42 s", "3 min 05 s", "2 h 07 min": a duration a user reads at a glance.
std::string readableDuration(double seconds);

}  // namespace overlap::engine
