#include "engine/program/progress.h"

#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdio>

#include "engine/program/wording.h"
#include "gpu/base/interrupt.h"
#include "gpu/base/standard_streams.h"

namespace overlap::engine {
namespace {

std::atomic<Progress*> reporting{nullptr};

extern "C" void onTick(int) {
  const int saved = errno;
  if (Progress* progress = reporting.load()) progress->report();
  errno = saved;
}

void setTimer(bool on) {
  itimerval interval{};
  if (on) interval.it_value = interval.it_interval = timeval{1, 0};
  setitimer(ITIMER_REAL, &interval, nullptr);
}

double since(const timespec& start) {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<double>(now.tv_sec - start.tv_sec) +
         static_cast<double>(now.tv_nsec - start.tv_nsec) * 1e-9;
}

// A line built without allocating or locking (snprintf is neither
// async-signal-safe nor needed).
class Line {
 public:
  Line& text(const char* text) {
    while (*text != '\0' && size_ < sizeof(bytes_) - 1) bytes_[size_++] = *text++;
    return *this;
  }
  Line& number(long long value) {
    char digits[24];
    int count = 0;
    do {
      digits[count++] = static_cast<char>('0' + value % 10);
      value /= 10;
    } while (value > 0 && count < 23);
    while (count > 0 && size_ < sizeof(bytes_) - 1) bytes_[size_++] = digits[--count];
    return *this;
  }
  Line& twoDigits(long long value) { return value < 10 ? text("0").number(value) : number(value); }
  Line& duration(double seconds) {
    const auto whole = static_cast<long long>(seconds + 0.5);
    if (whole < 60) return number(whole).text(" s");
    if (whole < 3600) return number(whole / 60).text(" min ").twoDigits(whole % 60).text(" s");
    return number(whole / 3600).text(" h ").twoDigits(whole / 60 % 60).text(" min");
  }
  void print() {
    bytes_[size_++] = '\n';
    if (pendingInterrupt() != 0) return;  // the stop's own line comes next
    writeMessage(bytes_, size_);
  }

 private:
  char bytes_[512];
  std::size_t size_ = 0;
};

}  // namespace

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

Progress::Progress(std::string label, int total) : label_(std::move(label)), total_(total) {
  clock_gettime(CLOCK_MONOTONIC, &start_);
  struct sigaction action {};
  action.sa_handler = onTick;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;  // system calls go on, uninterrupted
  sigaction(SIGALRM, &action, nullptr);
  paused_ = reporting.exchange(this);
  setTimer(true);
}

Progress::~Progress() {
  if (!finished_) {
    setTimer(paused_ != nullptr);
    reporting.store(paused_);
  }
}

double Progress::seconds() const {
  return since(start_);
}

void Progress::report() {
  const double elapsed = since(start_);
  const int done = done_.load(std::memory_order_relaxed);
  const bool first = lines_.fetch_add(1) == 0;
  Line line;
  line.text(label_.c_str()).text(": ");
  if (total_ <= 0) {
    line.duration(elapsed).text(" elapsed").print();
    return;
  }
  if (done == 0) {
    line.text("0/").number(total_).text(" frames, ").duration(elapsed);
    line.text(" elapsed, the first frame still running").print();
    return;
  }
  const double left = elapsed * (total_ - done) / done;
  if (first) {
    Line estimate;
    estimate.text(label_.c_str()).text(": ").number(total_);
    estimate.text(" frames; at the first frames' pace the whole takes about ");
    estimate.duration(elapsed + left).print();
  }
  line.number(done).text("/").number(total_).text(" frames, ").duration(elapsed);
  line.text(" elapsed, about ").duration(left).text(" left").print();
}

void Progress::finish() {
  if (finished_) return;
  finished_ = true;
  setTimer(paused_ != nullptr);
  reporting.store(paused_);
  if (lines_.load() == 0) return;
  if (total_ > 0) {
    std::fprintf(stderr, "%s: done, %s in %s\n", label_.c_str(), counted(total_, "frame").c_str(),
                 readableDuration(seconds()).c_str());
  } else {
    std::fprintf(stderr, "%s: done in %s\n", label_.c_str(), readableDuration(seconds()).c_str());
  }
}

}  // namespace overlap::engine
