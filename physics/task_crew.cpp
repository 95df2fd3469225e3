#include "physics/task_crew.h"

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace overlap::physics {
namespace {

// Busy-waits politely: the CPU's pause at first, then the OS's yield, so a
// helper waiting out a serial phase gives its core to whoever needs it.
class Backoff {
 public:
  void pause() {
    if (spins_ < kSpinsBeforeYield) {
      ++spins_;
#if defined(__x86_64__) || defined(__i386__)
      _mm_pause();
#endif
    } else {
      std::this_thread::yield();
    }
  }

 private:
  static constexpr int kSpinsBeforeYield = 4096;  // some tens of microseconds
  int spins_ = 0;
};

}  // namespace

// The open loop and its counters.  `epoch` is even while a loop is open and
// odd between loops; the loop's fields are written only while it is odd and
// no helper is registered (`busy` 0).  A helper registers (busy + 1) and then
// checks that the epoch it saw is still open; the caller closes a loop (odd
// epoch) and then waits for `busy` to drop: sequentially consistent on both
// sides, so either the helper sees the loop closed and leaves its fields
// alone, or the caller sees the helper and waits for it.  Each counter has a
// cache line of its own: a loop lasts microseconds, and a line that two
// cores pass back and forth costs a tenth of one each time.
struct TaskCrew::Shared {
  static constexpr std::size_t kLine = 64;

  // One share of a loop's pieces per thread: [next, end), taken one piece at
  // a time by its thread and then by any thread done with its own.
  struct alignas(kLine) Share {
    std::atomic<std::size_t> next{0};
    std::size_t end = 0;
  };

  explicit Shared(int threads) : shares(static_cast<std::size_t>(threads)) {}

  alignas(kLine) std::atomic<std::uint64_t> epoch{1};
  alignas(kLine) std::atomic<int> busy{0};
  alignas(kLine) std::atomic<std::size_t> done{0};  // pieces ended
  // The open loop, read-only while it is open.
  alignas(kLine) const TaskSystem::PieceBody* body = nullptr;
  std::size_t count = 0;
  std::size_t grain = 1;
  std::size_t pieces = 0;
  std::atomic<bool> failed{false};
  std::atomic<bool> ending{false};
  std::vector<Share> shares;
  std::mutex error_mutex;
  std::exception_ptr error;  // guarded by error_mutex

  // The loop's pieces in one contiguous share a thread: consecutive pieces
  // touch nearby bodies, so each thread's bodies stay in its own cache from
  // one loop to the next.
  void share(std::size_t loop_pieces) {
    const std::size_t threads = shares.size();
    for (std::size_t t = 0; t < threads; ++t) {
      shares[t].next.store(t * loop_pieces / threads, std::memory_order_relaxed);
      shares[t].end = (t + 1) * loop_pieces / threads;
    }
  }

  // Runs thread `self`'s share, then whatever is left of the others'.
  void runPieces(std::size_t self) {
    const std::size_t threads = shares.size();
    for (std::size_t k = 0; k < threads; ++k) {
      Share& share = shares[(self + k) % threads];
      std::size_t ran = 0;
      for (std::size_t piece = share.next.fetch_add(1, std::memory_order_relaxed);
           piece < share.end; piece = share.next.fetch_add(1, std::memory_order_relaxed)) {
        ++ran;
        if (failed.load(std::memory_order_relaxed)) continue;
        try {
          (*body)(piece * grain, std::min(count, (piece + 1) * grain));
        } catch (...) {
          const std::lock_guard lock(error_mutex);
          if (!error) error = std::current_exception();
          failed.store(true, std::memory_order_relaxed);
        }
      }
      if (ran != 0) done.fetch_add(ran, std::memory_order_release);
    }
  }

  // Helper `self`'s life: each loop it finds open, until the crew ends.
  void help(std::size_t self) {
    std::uint64_t seen = 1;
    Backoff backoff;
    while (!ending.load(std::memory_order_acquire)) {
      const std::uint64_t open = epoch.load(std::memory_order_seq_cst);
      if ((open & 1) != 0 || open == seen) {
        backoff.pause();
        continue;
      }
      busy.fetch_add(1, std::memory_order_seq_cst);
      if (epoch.load(std::memory_order_seq_cst) == open) runPieces(self);
      busy.fetch_sub(1, std::memory_order_seq_cst);
      seen = open;
      backoff = Backoff{};
    }
  }
};

TaskCrew::TaskCrew(TaskSystem& tasks, TaskGroup& helpers)
    : shared_(std::make_shared<Shared>(tasks.threads())), threads_(tasks.threads()) {
  for (int helper = 1; helper < tasks.threads(); ++helper) {
    helpers.run([shared = shared_, helper] { shared->help(static_cast<std::size_t>(helper)); });
  }
}

TaskCrew::~TaskCrew() {
  shared_->ending.store(true, std::memory_order_release);
}

void TaskCrew::forEachPiece(std::size_t count, std::size_t grain,
                            const TaskSystem::PieceBody& body) {
  const std::size_t pieces = pieceCount(count, grain);
  Shared& shared = *shared_;
  if (threads_ == 1 || pieces <= 1) {
    for (std::size_t piece = 0; piece < pieces; ++piece) {
      body(piece * grain, std::min(count, (piece + 1) * grain));
    }
    return;
  }
  // Between loops: the epoch is odd and no helper is registered.
  shared.body = &body;
  shared.count = count;
  shared.grain = grain;
  shared.pieces = pieces;
  // Which thread runs a piece never changes what it computes.
  shared.share(pieces);
  shared.done.store(0, std::memory_order_relaxed);
  shared.failed.store(false, std::memory_order_relaxed);
  const std::uint64_t closed = shared.epoch.load(std::memory_order_relaxed);
  shared.epoch.store(closed + 1, std::memory_order_seq_cst);
  shared.runPieces(0);
  Backoff backoff;
  while (shared.done.load(std::memory_order_acquire) != pieces) backoff.pause();
  shared.epoch.store(closed + 2, std::memory_order_seq_cst);
  backoff = Backoff{};
  while (shared.busy.load(std::memory_order_seq_cst) != 0) backoff.pause();
  if (shared.error) {
    std::exception_ptr error;
    std::swap(error, shared.error);
    std::rethrow_exception(error);
  }
}

}  // namespace overlap::physics
