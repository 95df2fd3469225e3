// Runs a pair finder that searches inside launch() (cpubf) on a worker
// thread of its own, so that launch() returns at once and the caller's thread
// is free for other work until finish(), as it is with the GPU finders.
//
// The worker is started once and sleeps between frames; launch() copies the
// objects, so the caller may change its array while the search runs.  The
// inner finder is only touched by the worker between launch() and finish(),
// and only by the caller otherwise: the hand-over is a mutex and a condition.
#pragma once

#include <chrono>
#include <condition_variable>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "gpu/pair_finder.h"

namespace overlap::gpu {

class BackgroundPairFinder final : public PairFinder {
 public:
  explicit BackgroundPairFinder(std::unique_ptr<PairFinder> inner);
  ~BackgroundPairFinder() override;
  BackgroundPairFinder(const BackgroundPairFinder&) = delete;
  BackgroundPairFinder& operator=(const BackgroundPairFinder&) = delete;

  std::string_view name() const override { return inner_->name(); }
  void launch(std::span<const ObjectBounds> objects) override;
  PairDelta finish() override;
  double lastSearchMs() const override { return inner_->lastSearchMs(); }
  double lastSearchDelayMs() const override { return search_delay_ms_; }

 private:
  void work();

  std::unique_ptr<PairFinder> inner_;
  std::vector<ObjectBounds> objects_;
  PairDelta delta_;
  std::exception_ptr error_;
  std::chrono::steady_clock::time_point requested_at_;
  double search_delay_ms_ = 0;

  std::mutex mutex_;
  std::condition_variable changed_;
  bool requested_ = false;  // a search is waiting for the worker
  bool done_ = false;       // the worker finished the search
  bool in_flight_ = false;  // between launch() and finish(); caller's thread only
  bool stopping_ = false;
  std::thread worker_;  // last: started after everything it reads exists
};

}  // namespace overlap::gpu
