#include "gpu/background_pair_finder.h"

#include <stdexcept>
#include <string>
#include <utility>

namespace overlap::gpu {

BackgroundPairFinder::BackgroundPairFinder(std::unique_ptr<PairFinder> inner)
    : inner_(std::move(inner)), worker_([this] { work(); }) {}

BackgroundPairFinder::~BackgroundPairFinder() {
  {
    const std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  worker_.join();
}

void BackgroundPairFinder::launch(std::span<const ObjectBounds> objects) {
  if (in_flight_) {
    throw std::runtime_error(std::string(name()) + ": launch() called twice without finish()");
  }
  {
    const std::lock_guard lock(mutex_);
    objects_.assign(objects.begin(), objects.end());
    requested_ = true;
    requested_at_ = std::chrono::steady_clock::now();
    done_ = false;
  }
  in_flight_ = true;
  changed_.notify_all();
}

PairDelta BackgroundPairFinder::finish() {
  if (!in_flight_) {
    throw std::runtime_error(std::string(name()) + ": finish() called without launch()");
  }
  in_flight_ = false;
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [this] { return done_; });
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
  return delta_;
}

void BackgroundPairFinder::work() {
  std::unique_lock lock(mutex_);
  for (;;) {
    changed_.wait(lock, [this] { return requested_ || stopping_; });
    if (stopping_) return;
    requested_ = false;
    search_delay_ms_ =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - requested_at_)
            .count();
    // The caller waits in finish() for done_, and touches nothing meanwhile,
    // so the search can run unlocked.
    lock.unlock();
    try {
      inner_->launch(objects_);
      delta_ = inner_->finish();
    } catch (...) {
      error_ = std::current_exception();
    }
    lock.lock();
    done_ = true;
    changed_.notify_all();
  }
}

}  // namespace overlap::gpu
