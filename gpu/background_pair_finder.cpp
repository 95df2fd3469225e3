#include "gpu/background_pair_finder.h"

#include <stdexcept>
#include <string>
#include <utility>

namespace overlap::gpu {

BackgroundPairFinder::BackgroundPairFinder(std::unique_ptr<PairFinder> inner)
    : inner_(std::move(inner)) {}

BackgroundPairFinder::~BackgroundPairFinder() noexcept {
  if (in_flight_) join();  // never leave a job that reads our members running
}

void BackgroundPairFinder::launch(std::span<const ObjectBounds> objects) {
  if (in_flight_) {
    throw std::runtime_error(std::string(name()) + ": launch() called twice without finish()");
  }
  objects_.assign(objects.begin(), objects.end());
  error_ = nullptr;
  requested_at_ = std::chrono::steady_clock::now();
  arena_.execute([this] { job_.run([this] { search(); }); });
  in_flight_ = true;
}

PairDelta BackgroundPairFinder::finish() {
  if (!in_flight_) {
    throw std::runtime_error(std::string(name()) + ": finish() called without launch()");
  }
  join();
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
  launch_to_finish_ms_ =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - requested_at_)
          .count();
  return delta_;
}

void BackgroundPairFinder::join() {
  in_flight_ = false;
  // Waiting inside the arena: the caller takes the job if no worker has.
  arena_.execute([this] { job_.wait(); });
}

void BackgroundPairFinder::search() {
  search_delay_ms_ =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - requested_at_)
          .count();
  try {
    inner_->launch(objects_);
    delta_ = inner_->finish();
  } catch (...) {
    error_ = std::current_exception();  // handed to the caller by finish()
  }
}

}  // namespace overlap::gpu
