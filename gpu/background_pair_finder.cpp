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
  changes_known_ = false;
  start();
}

void BackgroundPairFinder::launchWithChanges(std::span<const ObjectBounds> objects,
                                             std::span<const std::uint32_t> changed) {
  if (in_flight_) {
    throw std::runtime_error(std::string(name()) + ": launch() called twice without finish()");
  }
  changes_known_ = objects.size() == objects_.size();
  if (changes_known_) {
    for (const std::uint32_t slot : changed) {
      if (slot >= objects.size()) {
        throw std::runtime_error(std::string(name()) + ": changed slot " + std::to_string(slot) +
                                 " is past the " + std::to_string(objects.size()) + " boxes");
      }
      objects_[slot] = objects[slot];
    }
    changed_.assign(changed.begin(), changed.end());
  } else {
    objects_.assign(objects.begin(), objects.end());
  }
  start();
}

void BackgroundPairFinder::start() {
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
    if (changes_known_) {
      inner_->launchWithChanges(objects_, changed_);
    } else {
      inner_->launch(objects_);
    }
    delta_ = inner_->finish();
  } catch (...) {
    error_ = std::current_exception();  // handed to the caller by finish()
  }
}

}  // namespace overlap::gpu
