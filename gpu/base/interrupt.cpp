#include "gpu/base/interrupt.h"

#include <time.h>  // clock_gettime, async-signal-safe

#include <algorithm>
#include <atomic>
#include <cerrno>  // program_invocation_short_name
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <string>
#include <vector>

namespace overlap {
namespace {

// The first of SIGINT, SIGTERM and SIGHUP is stored with the time it came.
// A later one within kSameRequestNs of it is the same request, delivered
// twice (timeout(1) signals the process, then its group), and is dropped;
// any later one, of the same kind or another, ends the process by its own
// default action (the shell sees it killed by that signal).  Only
// async-signal-safe calls (clock_gettime, sigaction, raise): the signal is
// blocked while its handler runs, so raise() delivers it, now undefended,
// as the handler returns.
constexpr std::int64_t kSameRequestNs = 1'000'000'000;
std::atomic<std::int64_t> first_signal_ns{0};
static_assert(std::atomic<std::int64_t>::is_always_lock_free, "the handler stores into it");

extern "C" void onSignal(int signal_number) {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  // Never 0, which marks "none yet".
  const std::int64_t now_ns = std::int64_t{now.tv_sec} * 1'000'000'000 + now.tv_nsec + 1;
  std::int64_t first_ns = 0;
  if (first_signal_ns.compare_exchange_strong(first_ns, now_ns, std::memory_order_relaxed)) {
    interrupt_detail::received.store(signal_number, std::memory_order_relaxed);
    return;
  }
  if (now_ns - first_ns < kSameRequestNs) return;
  struct sigaction fallback {};
  fallback.sa_handler = SIG_DFL;
  sigemptyset(&fallback.sa_mask);
  sigaction(signal_number, &fallback, nullptr);
  raise(signal_number);
}

// A wait this long is said on stderr: shorter ones are a pipe's normal pace.
constexpr auto kSilentWait = std::chrono::seconds(1);
// The longest a wait goes without looking at the flag (a signal that lands
// just before a blocking call is seen within this).
constexpr int kCheckEveryMs = 100;

}  // namespace

const char* signalName(int signal_number) {
  switch (signal_number) {
    case SIGINT:
      return "SIGINT";
    case SIGTERM:
      return "SIGTERM";
    case SIGHUP:
      return "SIGHUP";
    default:
      return "a signal";
  }
}

Interrupted::Interrupted(int signal_number, const std::string& where)
    : std::runtime_error(std::string(signalName(signal_number)) + " at " + where),
      signal(signal_number),
      where(where) {}

void catchInterrupts() {
  struct sigaction action {};
  action.sa_handler = onSignal;
  sigemptyset(&action.sa_mask);
  // No SA_RESTART: a blocking read, write or open returns EINTR, so the wait
  // it was in sees the flag at once.
  // Not SA_RESETHAND, which resets only the handler of the signal that
  // came: a second signal of another kind must end the process too.
  action.sa_flags = 0;
  for (const int signal_number : {SIGINT, SIGTERM, SIGHUP}) {
    // A signal ignored when the program started stays ignored: `nohup`, a
    // shell's `trap '' INT` or a background job asked for that.
    struct sigaction inherited {};
    if (sigaction(signal_number, nullptr, &inherited) == 0 && inherited.sa_handler == SIG_IGN) {
      continue;
    }
    sigaction(signal_number, &action, nullptr);
  }
  std::signal(SIGPIPE, SIG_IGN);
  std::signal(SIGXFSZ, SIG_IGN);  // past `ulimit -f` a write fails with EFBIG instead
}

void stopIfInterrupted(const std::string& where) {
  if (const int signal_number = pendingInterrupt(); signal_number != 0) {
    throw Interrupted(signal_number, where);
  }
}

void waitUntil(const std::function<bool(int timeout_ms)>& ready, const std::string& waiting,
               const std::string& where) {
  const auto start = std::chrono::steady_clock::now();
  bool said = false;
  while (true) {
    stopIfInterrupted(where);
    if (ready(kCheckEveryMs)) return;
    if (!said && std::chrono::steady_clock::now() - start >= kSilentWait) {
      std::fprintf(stderr, "%s: %s\n", program_invocation_short_name, waiting.c_str());
      said = true;
    }
  }
}

namespace {

std::mutex written_through_mutex;
std::vector<std::string> written_through;  // guarded by written_through_mutex

}  // namespace

void noteWrittenThrough(const std::string& output) {
  const std::lock_guard lock(written_through_mutex);
  if (std::find(written_through.begin(), written_through.end(), output) == written_through.end()) {
    written_through.push_back(output);
  }
}

int reportInterrupted(const char* program, const Interrupted& original) {
  Interrupted stop = original;
  {
    const std::lock_guard lock(written_through_mutex);
    for (const std::string& output : written_through) {
      if (!stop.already_sent.empty()) stop.already_sent += ", ";
      stop.already_sent += output + " (written as it went)";
    }
  }
  if (stop.already_sent.empty()) {
    std::fprintf(stderr,
                 "%s: stopped by %s; kept nothing of this run: its temporaries are removed and "
                 "the outputs hold what they held before\n",
                 program, stop.what());
  } else {
    std::fprintf(stderr,
                 "%s: stopped by %s; already sent, and staying sent: %s; kept nothing else: "
                 "its temporaries are removed and the output files hold what they held before\n",
                 program, stop.what(), stop.already_sent.c_str());
  }
  return 128 + stop.signal;
}

}  // namespace overlap
