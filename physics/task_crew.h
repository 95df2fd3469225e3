// A crew: the task system's other threads held by one caller for a run of
// short parallel loops, each opened and joined by atomics alone.  The
// coloured solver runs thousands of loops a frame, one per colour and sweep,
// of some microseconds of rows each, where a TaskSystem::forEachPiece per
// loop (a oneTBB parallel_for, its threads woken and joined) costs a large
// share of the rows' own time.  Box2D v3's solver stages are the model.
//
// Rules, each with its reason:
// - forEachPiece(count, grain, body) splits [0, count) into the pieces
//   TaskSystem::forEachPiece makes (they depend on count and grain alone),
//   runs each once, and returns when all have ended, so a loop that merges
//   per-piece results in piece order gives the same bits on any number of
//   threads.  A piece that throws: the pieces not yet started are skipped,
//   and the first error is rethrown once every started piece has ended.
// - The caller works every loop, and no loop waits for a helper to arrive:
//   a helper job still queued behind other work (the frame's sound and AI
//   jobs) is never needed, so the crew cannot stall on a busy system, and
//   on one thread every loop runs on the caller, in piece order.
// - Helpers spin between loops (yielding after a while) and leave when the
//   crew ends; a helper job that starts after that returns at once, and it
//   touches only the crew's shared state, which it co-owns.  While a crew
//   lives its helpers hold their threads: the caller's parallel loops go
//   through the crew, not through the task system.
// - Each thread first runs a contiguous share of a loop's pieces, then helps
//   with what is left of the others': consecutive pieces touch nearby
//   bodies, so a thread keeps its bodies in its own cache from loop to loop.
// - A crew is used from the thread that made it, one loop at a time.
#pragma once

#include <cstddef>
#include <memory>

#include "gpu/task_system.h"

namespace overlap::physics {

class TaskCrew {
 public:
  // Starts up to tasks.threads() - 1 helper jobs in `helpers`, a group that
  // must outlive the crew (its destructor waits for late helper jobs).
  TaskCrew(TaskSystem& tasks, TaskGroup& helpers);
  ~TaskCrew();
  TaskCrew(const TaskCrew&) = delete;
  TaskCrew& operator=(const TaskCrew&) = delete;

  void forEachPiece(std::size_t count, std::size_t grain, const TaskSystem::PieceBody& body);

 private:
  struct Shared;
  std::shared_ptr<Shared> shared_;
  int threads_;  // the task system's, the caller's included
};

}  // namespace overlap::physics
