// Pair finders: the broadphase cores (brute forces and sort-and-sweep), free of Bullet.
//
// A PairFinder owns a set of object slots (index = slot) and, each frame,
// finds every pair a < b whose AABBs overlap (inclusive: touching counts) and
// whose collision filters accept each other:
//   (group[a] & mask[b]) != 0 && (group[b] & mask[a]) != 0.
// It remembers last frame's answer and reports only what changed: the pairs
// that started overlapping and the pairs that stopped.  An unused slot has
// group = mask = 0 and so pairs with nothing.
//
// A search has two calls: launch() takes the boxes and starts the search
// (the GPU finders queue it on their CUDA stream and return; the CPU finders
// search inside launch()); finish() waits for it and returns the changes.
// Both are called from one thread, strictly alternating; launch() copies
// what it needs, so the caller may change its boxes as soon as launch()
// returns.  The split lets a caller put work between the two or time the
// whole (the benchmark times launch to finish); the Bullet adapter,
// physics/broadphase/pair_finder_broadphase.h, calls them back to back.  The base class
// PairFinder enforces that order and keeps the launch-to-finish clock for
// every finder; a finder implements its hooks and reports its search in one
// record, SearchStats.  Every finder has a row in the table of finders
// (PairFinderRow, pairFinderTable()), by which it is made by name.
//
// The boxes and pairs it speaks in (ObjectBounds, IndexPair) are plain values
// of gpu/pairs/pair_types.h.
//
// Invariants: added and removed are sorted by (a, b), hold no duplicates, and
// are disjoint; the slot count may grow between frames (new slots start with
// no pairs) but never shrinks.  The per-pair rules live in gpu/pairs/pair_logic.h,
// shared by every finder.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

#include "gpu/pairs/pair_types.h"
#include "gpu/task_system.h"

namespace overlap::finders {

// What changed since the previous frame; valid until the next launch().
struct PairDelta {
  std::span<const IndexPair> added;
  std::span<const IndexPair> removed;
};

// Where a search's time went, for the finders that split it (cpusap); zero
// where a finder does not.
struct SearchPhases {
  double sort_ms = 0;   // sorting the boxes (or finding the moved ones)
  double sweep_ms = 0;  // finding the overlapping pairs
  double delta_ms = 0;  // turning them into added and removed pairs
};

// What the last finished search did on the device and on the host around it,
// for the benchmark's GPU columns and for counting host work without a GPU.
// Zero on the CPU finders.  Device times are CUDA events around each stage
// (what falls outside every stage, e.g. waiting behind other work, is in
// none); the counts are exact.
struct DeviceWork {
  double upload_ms = 0;    // boxes, host to device
  double kernels_ms = 0;   // from the first kernel's start to the last one's end
  double download_ms = 0;  // results, device to host
  std::uint64_t bytes_to_device = 0;
  std::uint64_t bytes_from_device = 0;
  std::uint64_t api_calls = 0;            // CUDA runtime calls made by launch() and finish()
  std::uint64_t host_bytes_copied = 0;    // bytes memcpy'd on the host (staging, list joins)
  std::uint64_t host_entries_sorted = 0;  // entries sorted on the host
};

// Everything a finder reports of its last finished search, in one record
// (PairFinder::lastStats()).
struct SearchStats {
  // By the finder's own clock: on the GPU finders CUDA events from before the
  // upload to after the last copy back (device time: the host's work around
  // it is not in it), on the CPU the searching thread's clock.
  double search_ms = 0;
  // On the host's clock, from launch()'s entry to finish()'s return, whatever
  // the caller did between.
  double launch_to_finish_ms = 0;
  SearchPhases phases;
  DeviceWork device;
};

// A frame with more pairs than the finder's pair limit (setPairLimit()):
// finish() throws it.  The finder stopped collecting them when the limit was
// passed, so it held lists for about that many pairs, not for the frame's.
class PairLimitError : public std::runtime_error {
 public:
  PairLimitError(std::string_view finder, std::uint64_t most_pairs);
  std::uint64_t most_pairs;  // the limit; the frame had more
};

// The interface every finder implements.  The base class keeps the calls'
// order and the launch-to-finish clock, once for every finder: launch()
// (or launchWithChanges()) and finish() strictly alternate, stagingFor()
// only between frames; a call out of order throws std::runtime_error naming
// the finder and leaves it as it was.  A launch() that throws starts no
// frame (finish() then refuses); a finish() that throws ends its frame.  A
// finder implements the protected hooks, which the base calls in order only.
class PairFinder {
 public:
  virtual ~PairFinder() = default;
  virtual std::string_view name() const = 0;
  // Starts this frame's search over objects[0..n).  n must not shrink.
  void launch(std::span<const ObjectBounds> objects);
  // launch() from a caller that knows which boxes it changed since its last
  // launch: every slot whose box differs from that launch's is in `changed`,
  // each once (a slot that did not change may be there too).  A finder that
  // re-queries only moved boxes (cpusap) then skips comparing every box, so a
  // frame where few moved costs in proportion to them (Box2D's move buffer).
  void launchWithChanges(std::span<const ObjectBounds> objects,
                         std::span<const std::uint32_t> changed);
  // Waits for the search started by launch() and returns what changed.
  PairDelta finish();
  // Room for `count` boxes that the caller may fill and then pass to
  // launch(), which then copies nothing on the host (gpubf: its pinned
  // staging).  Empty where the finder has none.  Write boxes only between
  // finish() (or construction) and launch().  While every launch passes the
  // staging, it keeps what the caller wrote: a call with a count no larger
  // than the last one's returns the same memory, contents and all, so the
  // caller need rewrite only the boxes that changed; a larger count may move
  // it and drop its contents (write all `count` boxes then).
  std::span<ObjectBounds> stagingFor(std::size_t count);
  // The last finished search's record (zeros before the first).
  SearchStats lastStats() const;
  // The most pairs a frame may have, 0 for no limit (the default), set
  // between frames: a frame with more is refused (PairLimitError), and the
  // finder is then spent: every later launch() throws the same error, since
  // it dropped the pairs it would compare the next frame with.
  void setPairLimit(std::uint64_t most_pairs);

 protected:
  // launch()'s work, called between frames only.  `changed` is null for
  // launch(), else launchWithChanges()'s list (a finder may ignore it).
  virtual void startSearch(std::span<const ObjectBounds> objects,
                           const std::span<const std::uint32_t>* changed) = 0;
  // finish()'s work, called only with a search started.
  virtual PairDelta finishSearch() = 0;
  // stagingFor()'s room, called between frames only.
  virtual std::span<ObjectBounds> staging(std::size_t /*count*/) { return {}; }
  // The last finished search's record but its launch_to_finish_ms, which the
  // base fills in; asked for only when the caller asks (lastStats()).
  virtual SearchStats searchStats() const = 0;
  // Milliseconds since the current (or last) launch() began.
  double msSinceLaunch() const;
  // The pair limit, UINT64_MAX where there is none.  A hook that finds a
  // frame's pairs (or its added ones, which are no more) passing it stops
  // collecting them and has finishSearch() throw pairLimitError().
  std::uint64_t pairLimit() const { return pair_limit_; }
  PairLimitError pairLimitError() const { return PairLimitError(name(), pair_limit_); }

 private:
  void start(std::span<const ObjectBounds> objects, const std::span<const std::uint32_t>* changed);

  std::uint64_t pair_limit_ = UINT64_MAX;
  std::optional<PairLimitError> spent_;  // the refusal that spent the finder
  bool in_flight_ = false;
  std::chrono::steady_clock::time_point launched_at_{};
  double launch_to_finish_ms_ = 0;
};

// True when a CUDA device can run the GPU finders; otherwise `why` (if not
// null) says why not.
bool cudaDeviceAvailable(std::string* why);

// The device the GPU finders use, e.g. "NVIDIA H100 80GB HBM3 (sm_90, 132 SMs)";
// empty when cudaDeviceAvailable() is false.
std::string cudaDeviceName();

// What a finder holds, host and device together, at its peak in a frame,
// as three rates: the memory bounds (engine/program/memory_bound.h) count a
// run from them before it allocates, so they are upper bounds, growth room
// included.  tests/gpu/finder_memory_test.cpp holds every finder to its own.
struct MemoryCost {
  std::uint32_t per_slot = 0;  // for each object slot
  double per_slot_pair = 0;    // for each pair of slots, overlapping or not (bit matrices)
  std::uint32_t per_pair = 0;  // for each overlapping pair, counting this frame's or the last's
  // The bytes for `slots` slots holding `pairs` pairs.
  std::uint64_t bytesFor(std::uint64_t slots, std::uint64_t pairs) const {
    const double slot_pairs = static_cast<double>(slots) * static_cast<double>(slots) / 2;
    return slots * per_slot + static_cast<std::uint64_t>(slot_pairs * per_slot_pair) +
           pairs * per_pair;
  }
};

// One row of the table of finders: all the program knows of a finder
// besides its own file.  Adding a finder is adding its row to the table
// (gpu/pair_finder_table.cpp); the broadphase catalogue, the CLI's names and
// --list-algos, and the tests over every finder follow from it.
struct PairFinderRow {
  std::string_view name;         // as --algo takes it
  bool needs_device;             // runs on a CUDA device
  std::string_view description;  // one line, for --list-algos
  // Makes one.  A CPU finder searches on `tasks`' threads, which must
  // outlive it; the GPU finders run their host work on the caller.
  std::unique_ptr<PairFinder> (*make)(TaskSystem& tasks);
  MemoryCost memory;  // what one holds
};

// The product's finders, CPU ones first: cpubf, cpusap, gpubf, gpubf-paper,
// gpusap.  A test may copy it and add rows of its own.
std::span<const PairFinderRow> pairFinderTable();

// The row of `table` named `name`; throws std::invalid_argument for a name
// not in it.
const PairFinderRow& pairFinderRow(std::string_view name,
                                   std::span<const PairFinderRow> table = pairFinderTable());

// Makes the finder named `name`.  A device finder needs cudaDeviceAvailable()
// and throws std::runtime_error with its reason otherwise.
std::unique_ptr<PairFinder> makePairFinder(
    std::string_view name, TaskSystem& tasks = defaultTaskSystem(),
    std::span<const PairFinderRow> table = pairFinderTable());

// The new slot count for a launch() over `objects` slots, after the checks
// every finder makes: it must not shrink below `previous` and must fit the
// 32-bit slot indices of IndexPair.  Throws std::runtime_error naming `finder`.
std::uint32_t checkedSlotCount(std::string_view finder, std::uint32_t previous,
                               std::size_t objects);

}  // namespace overlap::finders
