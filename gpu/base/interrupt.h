// The one signal path (docs/CLI.md, "Signals").  SIGINT, SIGTERM and SIGHUP
// only set a flag; every long loop calls stopIfInterrupted() at each frame
// boundary, and every wait (a FIFO without its reader or writer, a pipe
// whose writer stalls) goes through waitUntil(), which throws Interrupted.
// Unwinding removes every temporary (output_file.h) and publishes nothing,
// so the outputs hold what they held before; reportInterrupted() says so in
// one line, and the program exits 128 + the signal (129, 130, 143).
//
// Rules:
//   * A second signal, of the same kind or another (SIGTERM after SIGINT),
//     ends the process at once by that signal's default action: a stuck
//     run can always be stopped; only hidden temporaries
//     (".NAME.overlap-PID-XXXXXX") are then left beside the untouched
//     outputs, and the next run writing into that folder removes them
//     (output_file.h).  One that comes within a second of the first is
//     the same request delivered twice, and is dropped: timeout(1) sends
//     its signal to the process and then to its group, and the run must
//     still stop cleanly.
//   * SIGPIPE is ignored: a write to a pipe or FIFO whose reader has gone
//     fails with EPIPE like any failed write, so the writer names the output,
//     removes its temporaries and exits 1 instead of dying silently.
//   * SIGXFSZ is ignored too: a write past the file-size limit (`ulimit -f`)
//     fails with EFBIG ("File too large"), reported naming the file.
//   * The handlers only store the first signal's number and time, drop a
//     repeat, or restore the default action and raise a later one: nothing
//     else is async-signal-safe to do there.
#pragma once

#include <atomic>
#include <functional>
#include <stdexcept>
#include <string>

namespace overlap {

// what(): the signal's name and where it stopped ("SIGINT at frame 12 of 300").
struct Interrupted : std::runtime_error {
  Interrupted(int signal_number, const std::string& where);
  int signal;
  std::string where;  // "frame 12 of 300"
  // What of the run had already left the program when it stopped (rows
  // written to standard output), for the stop line; empty: nothing.
  std::string already_sent;
};

namespace interrupt_detail {
// The signal that arrived, or 0.  Inline, so that code built without this
// module's source (the installed pair finders) can look at it: there no
// handler is installed and it stays 0.
inline std::atomic<int> received{0};
static_assert(std::atomic<int>::is_always_lock_free, "the handler stores into it");
}  // namespace interrupt_detail

// Installs the handlers for SIGINT, SIGTERM and SIGHUP, leaving alone any of
// them that the program was started with ignored (`nohup`, `trap '' INT`),
// and ignores SIGPIPE and SIGXFSZ.
void catchInterrupts();

// The signal that arrived (SIGINT, SIGTERM, SIGHUP), or 0: a check cheap
// enough for a timed loop, which then builds its `where` only when needed.
// Header-only: a pair finder's search looks at it between its pieces and
// cuts the search short, leaving its caller (the world, the replay) to stop.
inline int pendingInterrupt() {
  return interrupt_detail::received.load(std::memory_order_relaxed);
}

// Throws Interrupted if a signal arrived; `where` ("frame 12 of 300") goes
// into the message.
void stopIfInterrupted(const std::string& where);

// Waits until `ready(timeout_ms)` (which waits at most that long) says yes.
// Between tries it stops for a signal (Interrupted at `where`), and once
// the wait has passed a second it says on stderr, once, "PROGRAM: `waiting`".
void waitUntil(const std::function<bool(int timeout_ms)>& ready, const std::string& waiting,
               const std::string& where);

// "SIGINT", "SIGTERM", "SIGHUP" ("a signal" for another).
const char* signalName(int signal_number);

// Prints the one "stopped by" line for `program` (with what was already
// sent, if anything) and returns the exit code, 128 + the signal.
int reportInterrupted(const char* program, const Interrupted& stop);

// Notes that `output` got bytes written as they went (an open descriptor, a
// FIFO, a device: gpu/base/output_file.h), which a stop cannot take back:
// reportInterrupted names it among what stays sent.
void noteWrittenThrough(const std::string& output);

}  // namespace overlap
