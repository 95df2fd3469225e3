#include "engine/tools/bench_replay.h"

#include <chrono>
#include <cmath>
#include <stdexcept>

#include "engine/program/memory_bound.h"
#include "engine/program/usage_error.h"
#include "engine/streams/stream_statistics.h"
#include "gpu/base/interrupt.h"
#include "gpu/pairs/grid_pair_checker.h"

namespace overlap::engine {
namespace {

using Clock = std::chrono::steady_clock;

double usSince(Clock::time_point start) {
  return std::chrono::duration<double, std::micro>(Clock::now() - start).count();
}

// SplitMix64's finalizer: a well-mixed hash of (seed, frame, object).
std::uint64_t mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

physics::PairList presentPairs(const physics::PairList& all,
                               const std::vector<std::uint8_t>& present) {
  physics::PairList kept;
  for (const auto& [a, b] : all) {
    if (present[static_cast<std::size_t>(a)] != 0 && present[static_cast<std::size_t>(b)] != 0) {
      kept.push_back({a, b});
    }
  }
  return kept;
}

// Each column's median over `frames`.
DeviceFigures columnMedians(const std::vector<DeviceFigures>& frames) {
  DeviceFigures medians{};
  std::vector<double> column(frames.size());
  for (std::size_t c = 0; c < medians.size(); ++c) {
    for (std::size_t f = 0; f < frames.size(); ++f) column[f] = frames[f][c];
    medians[c] = median(column);
  }
  return medians;
}

}  // namespace

DeviceFigures deviceFigures(const finders::DeviceWork& work) {
  return {1e3 * work.upload_ms,
          1e3 * work.kernels_ms,
          1e3 * work.download_ms,
          static_cast<double>(work.bytes_to_device),
          static_cast<double>(work.bytes_from_device),
          static_cast<double>(work.api_calls),
          static_cast<double>(work.host_bytes_copied),
          static_cast<double>(work.host_entries_sorted)};
}

double Row::deviceMedian(std::size_t column) const {
  std::vector<double> repeats;
  for (const DeviceFigures& figures : device) repeats.push_back(figures[column]);
  return median(std::move(repeats));
}

std::vector<std::uint8_t> presentObjects(std::uint64_t seed, int frame, int objects, double churn) {
  std::vector<std::uint8_t> present(static_cast<std::size_t>(objects), 1);
  if (churn <= 0) return present;
  const double absent = (1 - std::sqrt(1 - 4 * std::min(churn, 0.25))) / 2;
  const auto threshold = static_cast<std::uint64_t>(absent * 0x1.0p64);
  for (int i = 0; i < objects; ++i) {
    const std::uint64_t draw =
        mix(seed ^ mix((static_cast<std::uint64_t>(frame) << 32) | static_cast<std::uint32_t>(i)));
    present[static_cast<std::size_t>(i)] = draw < threshold ? 0 : 1;
  }
  return present;
}

std::vector<physics::PairList> gridCheckerReference(const physics::AabbStream& stream) {
  std::vector<physics::PairList> reference;
  std::vector<finders::ObjectBounds> bounds;
  for (int frame = 0; frame < stream.stored_frames; ++frame) {
    toSearchBounds(stream.frame(frame), bounds);
    physics::PairList pairs;
    for (const std::uint64_t key : finders::gridCheckerPairs(bounds)) {
      pairs.push_back({static_cast<std::uint32_t>(key >> 32), static_cast<std::uint32_t>(key)});
    }
    reference.push_back(std::move(pairs));
  }
  return reference;
}

namespace {

// One replay's figures of its measured frames, folded into its row as medians.
struct ReplaySamples {
  std::vector<double> frame_us, update_us, sort_us, sweep_us, delta_us, cache_us;
  std::vector<double> launch_to_finish_us;
  std::vector<DeviceFigures> device;

  void add(double elapsed_us, double updated_us,
           const std::optional<physics::ReplayPhases>& phases) {
    frame_us.push_back(elapsed_us);
    update_us.push_back(updated_us);
    if (!phases) return;  // Bullet's own broadphases split nothing
    const finders::SearchStats& search = phases->search;
    sort_us.push_back(1e3 * search.phases.sort_ms);
    sweep_us.push_back(1e3 * search.phases.sweep_ms);
    delta_us.push_back(1e3 * search.phases.delta_ms);
    cache_us.push_back(1e3 * phases->cache_update_ms);
    launch_to_finish_us.push_back(1e3 * search.launch_to_finish_ms);
    if (search.device.api_calls > 0) device.push_back(deviceFigures(search.device));
  }

  void foldInto(Row& row) {
    row.repeat_medians_us.push_back(median(std::move(frame_us)));
    row.update_us.push_back(median(std::move(update_us)));
    if (!sort_us.empty()) {
      row.sort_us.push_back(median(std::move(sort_us)));
      row.sweep_us.push_back(median(std::move(sweep_us)));
      row.delta_us.push_back(median(std::move(delta_us)));
      row.cache_us.push_back(median(std::move(cache_us)));
      row.launch_to_finish_us.push_back(median(std::move(launch_to_finish_us)));
    }
    if (!device.empty()) row.device.push_back(columnMedians(device));
  }
};

}  // namespace

void replayOnce(const physics::AabbStream& stream, int warmup, std::uint64_t seed,
                std::uint64_t max_memory_mb, std::vector<physics::PairList>& reference,
                bool has_reference, Row& row) {
  std::optional<physics::BroadphaseReplay> made;
  try {
    made.emplace(row.algorithm, stream.world, stream.objects);
  } catch (const std::invalid_argument& error) {  // e.g. sap beyond 32765 boxes
    throw UsageError(std::string(error.what()) + " (n = " + std::to_string(stream.objects) + ")");
  }
  physics::BroadphaseReplay& replay = *made;
  // The pairs get what the stream held and the replay's boxes leave.
  const auto objects = static_cast<std::uint64_t>(stream.objects);
  const std::uint64_t box_bytes =
      replayBytes(row.algorithm, objects) +
      objects * static_cast<std::uint64_t>(stream.stored_frames) * sizeof(physics::Aabb);
  // ... and the reference pairs held (which the reference run adds to).
  std::uint64_t reference_bytes = 0;
  for (const physics::PairList& frame_pairs : reference) {
    reference_bytes += frame_pairs.size() * sizeof(physics::PairList::value_type);
  }
  replay.setPairMemoryLimit(pairMemoryLimit(box_bytes + reference_bytes, max_memory_mb));
  if (replay.algorithm() != row.algorithm) {
    throw std::runtime_error("algorithm " + row.algorithm + " ran as " + replay.algorithm() + ": " +
                             replay.notice());
  }
  const bool fills_reference = has_reference && reference.empty();
  if (fills_reference && row.churn > 0) {
    throw std::logic_error("replayOnce: a churn replay cannot be the reference");
  }
  ReplaySamples samples;
  std::vector<std::uint32_t> changed;
  for (int frame = 0; frame < stream.stored_frames; ++frame) {
    const auto where = [&] {
      return "n=" + std::to_string(stream.objects) + " " + row.algorithm + ", frame " +
             std::to_string(frame) + " of " + std::to_string(stream.stored_frames);
    };
    const auto stopHere = [&] { stopIfInterrupted(where()); };
    if (pendingInterrupt() != 0) stopHere();  // before the clock starts
    std::vector<std::uint8_t> present;
    if (row.churn > 0) present = presentObjects(seed, frame, stream.objects, row.churn);
    // The boxes that changed, found before the clock starts: a world knows
    // which of its bodies are awake without comparing their boxes.
    const bool only_changed = frame > 0 && row.churn <= 0;
    if (only_changed) changedBoxes(stream.frame(frame - 1), stream.frame(frame), changed);
    const Clock::time_point start = Clock::now();
    double updated_us = 0;
    try {  // Bullet's own broadphases find pairs as the boxes are written
      if (only_changed) {
        replay.updateChanged(stream.frame(frame), changed);
      } else {
        replay.update(stream.frame(frame), present);
      }
      updated_us = usSince(start);
      replay.findPairs(where);
    } catch (const physics::PairMemoryError& error) {
      throw pairMemoryRefusal(error, max_memory_mb,
                              "n=" + std::to_string(stream.objects) + " with --algos " +
                                  row.algorithm + ", frame " + std::to_string(frame));
    } catch (const std::invalid_argument& error) {  // boxes sap's grid cannot hold
      throw UsageError("n=" + std::to_string(stream.objects) + ", frame " + std::to_string(frame) +
                       ": " + error.what());
    }
    const double elapsed_us = usSince(start);
    // After the clock: a signal cuts cpubf's search short, its pairs not whole.
    if (pendingInterrupt() != 0) stopHere();

    physics::PairList pairs = replay.pairs();
    const bool measured = frame >= warmup;
    if (measured) {
      samples.add(elapsed_us, updated_us, replay.lastPhases());
      row.pairs_sum += static_cast<double>(pairs.size());
    }
    if (fills_reference) {
      reference_bytes += pairs.size() * sizeof(physics::PairList::value_type);
      reference.push_back(std::move(pairs));
      replay.setPairMemoryLimit(pairMemoryLimit(box_bytes + reference_bytes, max_memory_mb));
    } else if (has_reference) {
      const physics::PairList& all = reference[static_cast<std::size_t>(frame)];
      const physics::PairList exact =
          row.churn > 0 ? presentPairs(all, present) : physics::PairList{};
      const physics::PairList& wanted = row.churn > 0 ? exact : all;
      const std::size_t extra = physics::countMissing(pairs, wanted);
      const std::size_t missed = physics::countMissing(wanted, pairs);
      if (measured) row.extra_sum += static_cast<double>(extra);
      row.missed += static_cast<long long>(missed);
      if (extra + missed > 0) ++row.mismatched_frames;
    }
  }
  samples.foldInto(row);
}

}  // namespace overlap::engine
