// One replay of the broadphase benchmark (engine/tools/bench_broadphase.cpp): a
// stream through one broadphase, each frame timed and checked, and the
// row of figures the replays of one (stream, algorithm, churn) add up to.
//
// A frame's time is update() (the boxes written into the broadphase, and
// with churn the proxies destroyed and created) plus findPairs(), on the
// steady clock.  With churn share s > 0, the objects absent in a frame are a
// fresh seeded draw, each with probability p, p (1 - p) = s, so that about
// s of the boxes are destroyed and s created every frame; the exact set of
// such a frame is the full frame's pairs between two present objects.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "engine/runtime/statistics.h"
#include "physics/aabb_stream.h"
#include "physics/broadphase_replay.h"

namespace overlap::engine {

// The GPU columns, in the CSV's order: what finders::DeviceWork reports of a
// frame (stage times by CUDA events, bytes over the bus, host work).
inline constexpr const char* kDeviceColumns[] = {
    "upload_us",         "kernels_us", "download_us",       "bytes_to_device",
    "bytes_from_device", "api_calls",  "host_bytes_copied", "host_entries_sorted"};
using DeviceFigures = std::array<double, std::size(kDeviceColumns)>;

// A frame's DeviceWork as the columns' figures (times in microseconds).
DeviceFigures deviceFigures(const finders::DeviceWork& work);

struct Row {
  int objects = 0;
  std::string algorithm;
  std::string stream;  // the --input file, empty for a recorded stream
  double churn = 0;    // share of boxes destroyed and created per frame
  int frames = 0;      // measured frames per repeat
  std::vector<double> repeat_medians_us;
  // Per repeat, the median measured frame's parts (our broadphases only):
  // update (setAabb), sort, sweep, delta, the pair-cache update.
  std::vector<double> update_us, sort_us, sweep_us, delta_us, cache_us;
  // Per repeat, the median measured frame's finder launch() to finish() on
  // the host (our broadphases only), and each GPU column's median over the
  // measured frames (only finders that report device work: gpubf, gpubf-paper).
  std::vector<double> launch_to_finish_us;
  std::vector<DeviceFigures> device;
  std::optional<std::string> reference;  // the exact set's algorithm, if any ran
  double pairs_sum = 0;
  double extra_sum = 0;
  long long mismatched_frames = 0;  // exact algorithms: frames that differ from the reference
  long long missed = 0;
  std::optional<double> ratio_vs_bvh;

  double medianUs() const { return median(repeat_medians_us); }
  double pairsMean() const { return pairs_sum / (frames * static_cast<double>(repeats())); }
  double extraMean() const { return extra_sum / (frames * static_cast<double>(repeats())); }
  int repeats() const { return static_cast<int>(repeat_medians_us.size()); }
  bool hasPhases() const { return !sort_us.empty(); }
  bool hasDeviceWork() const { return !device.empty(); }
  // Column `column`'s median over repeats.
  double deviceMedian(std::size_t column) const;
  // Whether its pairs were compared with a reference: not the reference's
  // own plain replay.
  bool checked() const { return reference && (algorithm != *reference || churn > 0); }
};

// Which objects are present in `frame` at churn share `churn` (all at 0).
std::vector<std::uint8_t> presentObjects(std::uint64_t seed, int frame, int objects, double churn);

// Every frame's exact pairs by gpu/pairs/grid_pair_checker.h.
std::vector<physics::PairList> gridCheckerReference(const physics::AabbStream& stream);

// Replays the whole stream once in a fresh broadphase and adds one repeat to
// `row`.  With `has_reference` and `reference` empty it fills it (this
// algorithm is the reference; only without churn); otherwise every frame is
// checked against it.  Throws UsageError for a count the algorithm cannot hold
// or pairs that --max-memory (`max_memory_mb`, engine/program/memory_bound.h) cannot,
// Interrupted (gpu/base/interrupt.h) for a signal, checked before each frame.
void replayOnce(const physics::AabbStream& stream, int warmup, std::uint64_t seed,
                std::uint64_t max_memory_mb, std::vector<physics::PairList>& reference,
                bool has_reference, Row& row);

}  // namespace overlap::engine
