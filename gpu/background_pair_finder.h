// Runs a pair finder that searches inside launch() (cpubf) as a oneTBB job,
// so that launch() returns at once and the search runs off the caller's
// thread, as the GPU finders' search runs on their CUDA stream.
//
// The finder has no thread of its own: the job runs in a oneTBB arena of
// its own, on a pool worker when one is free.  finish() joins by waiting
// inside that arena, so a caller whose workers are all busy (with the
// engine's sound and AI tasks, say) runs the job itself instead of sleeping,
// and otherwise helps the search's parallel loop.  Every thread involved is
// oneTBB's or the caller's, so a oneTBB thread cap (tbb::global_control, as
// `overlap run --threads` sets it) bounds the search too.
//
// Invariants: the inner finder is touched only by the job between launch()
// and finish(), and only by the caller otherwise; launch() copies the
// objects; a search in flight is always joined, by finish() or by the
// destructor.
#pragma once

#include <oneapi/tbb/task_arena.h>
#include <oneapi/tbb/task_group.h>

#include <chrono>
#include <cstdint>
#include <exception>
#include <memory>
#include <vector>

#include "gpu/pair_finder.h"

namespace overlap::gpu {

class BackgroundPairFinder final : public PairFinder {
 public:
  explicit BackgroundPairFinder(std::unique_ptr<PairFinder> inner);
  ~BackgroundPairFinder() noexcept override;  // joins a search in flight
  BackgroundPairFinder(const BackgroundPairFinder&) = delete;
  BackgroundPairFinder& operator=(const BackgroundPairFinder&) = delete;

  std::string_view name() const override { return inner_->name(); }
  void launch(std::span<const ObjectBounds> objects) override;
  // Copies only the changed boxes when the slot count is unchanged.
  void launchWithChanges(std::span<const ObjectBounds> objects,
                         std::span<const std::uint32_t> changed) override;
  PairDelta finish() override;
  double lastSearchMs() const override { return inner_->lastSearchMs(); }
  double lastSearchDelayMs() const override { return search_delay_ms_; }
  SearchPhases lastPhases() const override { return inner_->lastPhases(); }
  DeviceWork lastDeviceWork() const override { return inner_->lastDeviceWork(); }
  double lastLaunchToFinishMs() const override { return launch_to_finish_ms_; }

 private:
  void start();
  void search();
  void join();

  std::unique_ptr<PairFinder> inner_;
  std::vector<ObjectBounds> objects_;  // the last launch's boxes
  std::vector<std::uint32_t> changed_;
  bool changes_known_ = false;  // changed_ lists what differs from the launch before
  PairDelta delta_;
  std::exception_ptr error_;
  std::chrono::steady_clock::time_point requested_at_;
  double search_delay_ms_ = 0;
  double launch_to_finish_ms_ = 0;
  bool in_flight_ = false;  // between launch() and finish(); caller's thread only

  // Normal priority: a caller with other work for the pool (the engine's
  // tasks, at high priority) keeps its workers there, and joins the search
  // itself; an idle pool helps the search.
  tbb::task_arena arena_{tbb::task_arena::automatic, 1, tbb::task_arena::priority::normal};
  tbb::task_group job_;
};

}  // namespace overlap::gpu
