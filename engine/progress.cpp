#include "engine/progress.h"

#include <cstdio>

namespace overlap::engine {

std::string readableDuration(double seconds) {
  char text[48];
  const auto whole = static_cast<long long>(seconds + 0.5);
  if (whole < 60) {
    std::snprintf(text, sizeof(text), "%lld s", whole);
  } else if (whole < 3600) {
    std::snprintf(text, sizeof(text), "%lld min %02lld s", whole / 60, whole % 60);
  } else {
    std::snprintf(text, sizeof(text), "%lld h %02lld min", whole / 3600, whole / 60 % 60);
  }
  return text;
}

Progress::Progress(std::string label, int total)
    : label_(std::move(label)), total_(total), reporter_([this](std::stop_token stop) {
        std::unique_lock lock(mutex_);
        for (bool first = true;; first = false) {
          if (wake_.wait_for(lock, stop, std::chrono::seconds(1), [] { return false; }) ||
              stop.stop_requested()) {
            return;
          }
          report(first);
        }
      }) {}

Progress::~Progress() {
  reporter_.request_stop();
}

double Progress::seconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Progress::report(bool first) {
  const double elapsed = seconds();
  const int done = done_.load(std::memory_order_relaxed);
  reported_ = true;
  if (total_ <= 0) {
    std::fprintf(stderr, "%s: %s elapsed\n", label_.c_str(), readableDuration(elapsed).c_str());
    return;
  }
  if (done == 0) {
    std::fprintf(stderr, "%s: 0/%d frames, %s elapsed, the first frame still running\n",
                 label_.c_str(), total_, readableDuration(elapsed).c_str());
    return;
  }
  const double left = elapsed * (total_ - done) / done;
  if (first) {
    std::fprintf(stderr, "%s: %d frames; at the first frames' pace the whole takes about %s\n",
                 label_.c_str(), total_, readableDuration(elapsed + left).c_str());
  }
  std::fprintf(stderr, "%s: %d/%d frames, %s elapsed, about %s left\n", label_.c_str(), done,
               total_, readableDuration(elapsed).c_str(), readableDuration(left).c_str());
}

void Progress::finish() {
  reporter_.request_stop();
  if (reporter_.joinable()) reporter_.join();
  if (!reported_) return;
  if (total_ > 0) {
    std::fprintf(stderr, "%s: done, %d frames in %s\n", label_.c_str(), total_,
                 readableDuration(seconds()).c_str());
  } else {
    std::fprintf(stderr, "%s: done in %s\n", label_.c_str(), readableDuration(seconds()).c_str());
  }
}

}  // namespace overlap::engine
