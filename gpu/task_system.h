// The one task system of a run: the threads that every parallel part of the
// program shares (the CPU pair finders, the physics step's parallel parts,
// the frame's sound and AI jobs), in the manner of Jolt's JobSystem, which
// PhysicsSystem::Update takes from its caller.
//
// Rules, each with its reason:
// - threads() is fixed at construction; the caller's thread counts as one
//   of them, so a system of 1 thread runs everything on the caller.
// - forEachPiece(count, grain, body) splits [0, count) into pieces
//   [k * grain, min(count, (k + 1) * grain)), k = 0, 1, ...: the pieces
//   depend on count and grain alone, never on the thread count or on which
//   thread is free, so a loop that merges per-piece results in piece order
//   gives the same result on any number of threads.  Each piece runs once,
//   and the call returns when all have ended.  A piece may throw: the pieces
//   not yet started are then skipped, and forEachPiece rethrows the first
//   exception once every started piece has ended.
// - While a thread waits inside forEachPiece it runs only pieces of that
//   same loop (oneTBB's isolation): a piece never starts on a thread that is
//   in the middle of another piece of another loop, so per-thread scratch
//   (indexed by threadIndex()) is never shared by two live pieces.
// - threadIndex() is in [0, threads()) for the thread that made the system
//   and for its workers, distinct between threads that run at once.
// - A TaskGroup runs jobs beside the caller on the same threads; wait()
//   returns when all have ended and rethrows the first job's exception.
//   The group's destructor waits too: nothing a job touches can go away
//   under it.
// - kOneTbb is the default; kPlainThreads (std::thread and a queue) is the
//   back end of ThreadSanitizer builds, since Debian's oneTBB is not built
//   with TSan and its lock-free queues would be reported as races; both keep
//   the rules above, and tests run both.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>

namespace overlap {

enum class TaskBackEnd {
  kOneTbb,
  kPlainThreads,
};

// The back end a build uses when none is named: kPlainThreads under TSan.
TaskBackEnd defaultTaskBackEnd();

class TaskGroup {
 public:
  virtual ~TaskGroup() = default;
  // Starts job on one of the system's threads (or queues it for the next
  // free one).
  virtual void run(std::function<void()> job) = 0;
  // Returns when every job run so far has ended; rethrows the first error.
  virtual void wait() = 0;
};

class TaskSystem {
 public:
  using PieceBody = std::function<void(std::size_t first, std::size_t end)>;

  virtual ~TaskSystem() = default;
  virtual int threads() const = 0;
  virtual int threadIndex() const = 0;
  virtual void forEachPiece(std::size_t count, std::size_t grain, const PieceBody& body) = 0;
  virtual std::unique_ptr<TaskGroup> makeGroup() = 0;
};

// threads = 0: every hardware thread the process may use.  Throws
// std::invalid_argument for a negative count.
std::unique_ptr<TaskSystem> makeTaskSystem(int threads = 0,
                                           TaskBackEnd back_end = defaultTaskBackEnd());

// A system of every hardware thread, made at first use and kept for the
// process: what a package user gets who hands none in.
TaskSystem& defaultTaskSystem();

// The number of pieces forEachPiece makes of count at this grain.
constexpr std::size_t pieceCount(std::size_t count, std::size_t grain) {
  return grain == 0 ? 0 : (count + grain - 1) / grain;
}

// A grain that makes about pieces_per_thread pieces a thread of a system of
// `threads` (at least min_grain, at least 1): for loops whose pieces may
// differ by thread count, because each piece writes only its own output.
std::size_t grainFor(std::size_t count, int threads, std::size_t pieces_per_thread,
                     std::size_t min_grain);

}  // namespace overlap
