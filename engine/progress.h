// Progress on stderr for anything that can take more than two seconds: a
// reporter thread stays silent for the first second, then prints at most one
// line a second: the frames done, the time elapsed and the time left at the
// pace so far (its first line says how long the whole will take), or, for
// a step without frames (placing ten million boxes), the time elapsed.  A
// line is printed even while one long frame runs.  finish() closes with one
// line if any was printed; short runs print nothing.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <stop_token>
#include <string>
#include <thread>

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

 private:
  void report(bool first);

  std::string label_;
  int total_;
  std::atomic<int> done_{0};
  bool reported_ = false;  // the reporter's own, read after it stopped
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  std::mutex mutex_;
  std::condition_variable_any wake_;
  std::jthread reporter_;  // last: stopped and joined first
};

// "42 s", "3 min 05 s", "2 h 07 min": a duration a user reads at a glance.
std::string readableDuration(double seconds);

}  // namespace overlap::engine
