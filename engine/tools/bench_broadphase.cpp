// overlap_bench_broadphase: the broadphase benchmark.
//
// Every broadphase replays the same recorded scene-4 AABB streams
// (engine/streams/recorded_streams.h) through physics::BroadphaseReplay, in one process,
// so all algorithms see the same boxes on the same machine under the same
// load.  A frame's time is "upload to pair cache updated": update() (every
// box's setAabb) plus findPairs() (the search and the persistent pair-cache
// update), taken with the steady clock around both.  Each (n, algorithm)
// replays its stream `repeats` times, each time in a fresh broadphase; the
// repeats of one n are interleaved across the algorithms, so that a change in
// the machine's load lands on all of them.  A repeat's figure is the median
// frame after the warm-up frames; a row reports the median, the fastest and
// the slowest repeat, and the ratio to bvh (btDbvtBroadphase) at that n.
//
// Every frame's pair cache is checked against the exact set, taken from the
// first exact algorithm (in the catalogue's order, physics/broadphase/broadphase_factory.h)
// run at that n: an exact algorithm must match it, one that is not must hold
// all of it and may hold extra pairs.  A mismatch or a missed pair makes
// the run fail (exit 1) after it has written its results.
//
// GPU algorithms run only where a CUDA device is present; elsewhere they are
// skipped with a note, never measured as their CPU fallback.
//
// --input FILE.aabbs... replays those streams (any .aabbs, Broadmark's own
// included) instead of the recorded scene-4 ones, each with every --algos
// algorithm; --grid-check takes the exact set from gpu/pairs/grid_pair_checker.h,
// an exact finder that shares no code with cpusap, so every exact algorithm
// is checked (fit for 10^5-10^6 boxes, where cpubf is too slow); --churn
// adds, for each share s, rows in which about s of the boxes are destroyed
// and s created every frame (engine/tools/bench_replay.h); --stream-stats prints
// what each input asks of a broadphase (engine/streams/stream_statistics.h) and stops.
// Before any work, every input (header, size, boxes, frames against
// --warmup, boxes against the algorithms and --churn) and both outputs are
// checked: a bad one exits 2 naming it (docs/CLI.md).  The command line
// itself is engine/tools/bench_options.h's.
// Our broadphases' frames are split into update (setAabb), sort, sweep,
// delta and Bullet's pair-cache update.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <new>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "engine/program/csv.h"
#include "engine/program/machine_info.h"
#include "engine/program/memory_bound.h"
#include "engine/program/output_checks.h"
#include "engine/program/program_runner.h"
#include "engine/program/progress.h"
#include "engine/program/scene_options.h"
#include "engine/program/summary_output.h"
#include "engine/program/wording.h"
#include "engine/runtime/run_summary.h"
#include "engine/runtime/statistics.h"
#include "engine/streams/recorded_streams.h"
#include "engine/streams/stream_statistics.h"
#include "engine/tools/bench_options.h"
#include "engine/tools/bench_replay.h"
#include "gpu/base/interrupt.h"
#include "gpu/base/output_file.h"
#include "gpu/base/standard_streams.h"
#include "gpu/pair_finder.h"
#include "physics/broadphase/broadphase_factory.h"
#include "physics/broadphase_replay.h"

namespace overlap::engine {
namespace {

using Clock = std::chrono::steady_clock;
using physics::PairList;

constexpr const char* kProgram = "overlap_bench_broadphase";
constexpr int kScene = 4;

// One n of the run: its stream's length and the algorithms measured on it.
struct Workload {
  int objects;
  int record_frames;
  std::vector<std::string> algorithms;        // in broadphaseNames() order
  std::filesystem::path input;                // empty: the recorded scene-4 stream
  std::shared_ptr<physics::AabbStream> read;  // an --input without a size, read while checked
};

bool isExact(std::string_view algorithm) {
  return physics::broadphaseInfo(algorithm).exact;
}

std::vector<std::string> inNameOrder(const std::set<std::string>& algorithms) {
  std::vector<std::string> ordered;
  for (std::string_view name : physics::broadphaseNames()) {
    if (algorithms.contains(std::string(name))) ordered.emplace_back(name);
  }
  return ordered;
}

// Throws UsageError when a workload of `objects` boxes and `measured`
// frames cannot run as asked: an algorithm that cannot hold the boxes, a
// --churn share that would churn no box (fewer than one expected over the
// measured frames).
void checkWorkloadSize(const BenchOptions& options, const std::vector<std::string>& algorithms,
                       int objects, int measured, const std::string& where) {
  for (const std::string& algorithm : algorithms) {
    checkBroadphaseCapacity("--algos", algorithm, objects);
  }
  for (const double churn : options.churn) {
    if (churn * objects * measured < 1) {
      throw UsageError("--churn " + exactNumber(churn) + ": churns no box of " +
                       std::to_string(objects) + " over " + std::to_string(measured) +
                       " measured frames" + where + " (share x boxes x frames is below 1)");
    }
  }
}

// The run's workloads, GPU algorithms dropped (with `skipped` set) when no
// device can run them.  Throws UsageError for an empty or ambiguous plan.
std::vector<Workload> planWorkloads(const BenchOptions& options, std::string& skipped) {
  std::string why;
  const bool have_gpu = finders::cudaDeviceAvailable(&why);
  std::set<std::string> dropped;
  auto runnable = [&](const std::vector<std::string>& requested) {
    std::set<std::string> kept;
    for (const std::string& algorithm : requested) {
      if (physics::broadphaseInfo(algorithm).needs_device && !have_gpu) {
        dropped.insert(algorithm);
      } else {
        kept.insert(algorithm);
      }
    }
    return inNameOrder(kept);
  };

  std::map<int, Workload> by_objects;
  auto add = [&](const std::vector<int>& sizes, const std::vector<std::string>& algorithms,
                 int record_frames, const char* option) {
    for (int n : sizes) {
      if (n == 0) continue;  // "0: none"
      if (by_objects.contains(n)) {
        throw UsageError(std::string(option) + ": n = " + std::to_string(n) +
                         " is already in the run");
      }
      if (options.warmup > record_frames) {
        throw UsageError("--warmup " + std::to_string(options.warmup) + ": leaves no frame of " +
                         std::to_string(record_frames) +
                         " + 1 to measure at n = " + std::to_string(n));
      }
      if (!options.record_only && !options.stream_stats) {
        checkWorkloadSize(options, algorithms, n, record_frames + 1 - options.warmup,
                          " at n = " + std::to_string(n));
      }
      by_objects.emplace(n, Workload{n, record_frames, runnable(algorithms), {}, {}});
    }
  };
  if (!options.inputs.empty()) {
    std::vector<Workload> inputs;
    for (const std::filesystem::path& input : options.inputs) {
      inputs.push_back(Workload{0, 0, runnable(options.algorithms), input, {}});
    }
    if (!dropped.empty()) {
      skipped = "skipped " + CLI::detail::join(inNameOrder(dropped), ", ") + ": " + why;
    }
    return inputs;
  }
  add(options.objects, options.algorithms, options.record_frames, "--objects");
  add(options.big_objects, options.big_algorithms, options.big_record_frames, "--big-objects");
  if (by_objects.empty()) throw UsageError("--objects, --big-objects: nothing to run");

  if (!dropped.empty()) {
    skipped = "skipped " + CLI::detail::join(inNameOrder(dropped), ", ") + ": " + why;
  }
  std::vector<Workload> workloads;
  for (auto& [n, workload] : by_objects) workloads.push_back(std::move(workload));
  return workloads;
}

// The row whose pairs are the exact set: the first exact one (rows are in
// the catalogue's order), if any.
Row* referenceRow(std::vector<Row>& rows) {
  const auto exact =
      std::find_if(rows.begin(), rows.end(), [](const Row& row) { return isExact(row.algorithm); });
  return exact == rows.end() ? nullptr : &*exact;
}

std::string fixed(double value, int decimals) {
  char text[48];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}

std::vector<Row> measure(const Workload& workload, const physics::AabbStream& stream,
                         const BenchOptions& options, Clock::time_point run_start) {
  std::vector<double> churns = {0};
  churns.insert(churns.end(), options.churn.begin(), options.churn.end());
  for (const std::string& algorithm : workload.algorithms) {
    requireMemory(replayBytes(algorithm, static_cast<std::uint64_t>(stream.objects)),
                  options.max_memory_mb,
                  "n=" + std::to_string(stream.objects) + " with --algos " + algorithm);
  }
  std::vector<Row> rows;
  for (const double churn : churns) {
    for (const std::string& algorithm : workload.algorithms) {
      Row row;
      row.objects = stream.objects;
      row.algorithm = algorithm;
      row.stream = workload.input.string();
      row.churn = churn;
      row.frames = stream.stored_frames - options.warmup;
      rows.push_back(std::move(row));
    }
  }
  // The reference runs first in every repeat: its first replay fills the
  // exact set the others are checked against.  The grid checker's set, if
  // asked for, is there before any replay.
  std::vector<PairList> reference;
  if (options.grid_check) reference = gridCheckerReference(stream);
  std::vector<Row*> run_order;
  Row* const reference_row = options.grid_check ? nullptr : referenceRow(rows);
  if (reference_row != nullptr) run_order.push_back(reference_row);
  for (Row& row : rows) {
    if (options.grid_check) row.reference = "grid checker";
    if (reference_row != nullptr) row.reference = reference_row->algorithm;
    if (&row != reference_row) run_order.push_back(&row);
  }
  const bool has_reference = options.grid_check || reference_row != nullptr;

  for (int repeat = 0; repeat < options.repeats; ++repeat) {
    std::string line;
    for (Row* row : run_order) {
      Progress replaying(std::string(kProgram) + ": n=" + std::to_string(stream.objects) + " " +
                             row->algorithm + ", repeat " + std::to_string(repeat + 1) + " of " +
                             std::to_string(options.repeats),
                         0);
      replayOnce(stream, options.warmup, options.seed, options.max_memory_mb, reference,
                 has_reference, *row);
      replaying.finish();
      char figure[96];
      std::snprintf(figure, sizeof(figure), " %s%s %.1f us", row->algorithm.c_str(),
                    row->churn > 0 ? (" churn " + exactNumber(row->churn)).c_str() : "",
                    row->repeat_medians_us.back());
      line += figure;
    }
    const double elapsed = std::chrono::duration<double>(Clock::now() - run_start).count();
    std::fprintf(stderr, "%s: n=%d repeat %d/%d:%s (%.0f s elapsed)\n", kProgram, stream.objects,
                 repeat + 1, options.repeats, line.c_str(), elapsed);
  }

  for (Row& row : rows) {
    const auto bvh = std::find_if(rows.begin(), rows.end(), [&](const Row& other) {
      return other.algorithm == "bvh" && other.churn == row.churn;
    });
    if (bvh != rows.end()) row.ratio_vs_bvh = row.medianUs() / bvh->medianUs();
  }
  return rows;
}

// The run's failures, one line each: exact algorithms that disagree with the
// reference, conservative ones that missed a pair.
std::vector<std::string> failures(const std::vector<Row>& rows) {
  std::vector<std::string> found;
  for (const Row& row : rows) {
    std::string where = row.algorithm + " at n=" + std::to_string(row.objects);
    if (!row.stream.empty()) where += " (" + row.stream + ")";
    if (row.churn > 0) where += " with churn " + exactNumber(row.churn);
    if (isExact(row.algorithm) && row.mismatched_frames > 0) {
      found.push_back(where + ": pair cache differs from " + *row.reference + "'s on " +
                      counted(row.mismatched_frames, "frame"));
    } else if (row.missed > 0) {
      found.push_back(where + ": missed " + std::to_string(row.missed) + " overlapping pairs");
    }
  }
  return found;
}

std::string csvText(const std::vector<Row>& rows, const std::string& command,
                    const std::vector<std::string>& notes) {
  std::string csv = csvComment(machineSummary() + "; command: " + command);
  for (const std::string& note : notes) csv += csvComment(note);
  csv +=
      "n,algorithm,frames,repeats,median_us,min_us,max_us,ratio_vs_bvh,pairs_mean,"
      "extra_pairs_mean,missed_pairs,stream,churn,update_us,sort_us,sweep_us,delta_us,cache_us,"
      "launch_to_finish_us";
  for (const char* column : kDeviceColumns) csv += std::string(",") + column;
  csv += '\n';
  for (const Row& row : rows) {
    const auto [fastest, slowest] =
        std::minmax_element(row.repeat_medians_us.begin(), row.repeat_medians_us.end());
    const bool checked = row.checked();
    csv += std::to_string(row.objects) + ',' + csvField(row.algorithm) + ',' +
           std::to_string(row.frames) + ',' + std::to_string(row.repeats()) + ',' +
           fixed(row.medianUs(), 1) + ',' + fixed(*fastest, 1) + ',' + fixed(*slowest, 1) + ',' +
           (row.ratio_vs_bvh ? fixed(*row.ratio_vs_bvh, 3) : "") + ',' + fixed(row.pairsMean(), 1) +
           ',' + (checked ? fixed(row.extraMean(), 1) : "") + ',' +
           (checked ? std::to_string(row.missed) : "") + ',' + csvField(row.stream) + ',' +
           exactNumber(row.churn) + ',' + fixed(median(row.update_us), 1);
    for (const auto* phase : {&row.sort_us, &row.sweep_us, &row.delta_us, &row.cache_us}) {
      csv += ',' + (row.hasPhases() ? fixed(median(*phase), 1) : "");
    }
    csv += ',' + (row.hasPhases() ? fixed(median(row.launch_to_finish_us), 1) : "");
    for (std::size_t column = 0; column < std::size(kDeviceColumns); ++column) {
      csv += ',' + (row.hasDeviceWork() ? fixed(row.deviceMedian(column), column < 3 ? 1 : 0) : "");
    }
    csv += '\n';
  }
  return csv;
}

nlohmann::json rowJson(const Row& row) {
  const bool checked = row.checked();
  auto optional = [](bool present, auto value) {
    return present ? nlohmann::json(value) : nlohmann::json(nullptr);
  };
  return {{"n", row.objects},
          {"algorithm", row.algorithm},
          {"frames", row.frames},
          {"repeats", row.repeats()},
          {"median_us", row.medianUs()},
          {"min_us", *std::min_element(row.repeat_medians_us.begin(), row.repeat_medians_us.end())},
          {"max_us", *std::max_element(row.repeat_medians_us.begin(), row.repeat_medians_us.end())},
          {"repeat_medians_us", row.repeat_medians_us},
          {"ratio_vs_bvh", optional(row.ratio_vs_bvh.has_value(), row.ratio_vs_bvh.value_or(0))},
          {"pairs_mean", row.pairsMean()},
          {"reference", optional(row.reference.has_value(), row.reference.value_or(""))},
          {"extra_pairs_mean", optional(checked, row.extraMean())},
          {"missed_pairs", optional(checked, row.missed)},
          {"mismatched_frames", optional(checked && isExact(row.algorithm), row.mismatched_frames)},
          {"stream", row.stream},
          {"churn", row.churn},
          {"update_us", median(row.update_us)},
          {"sort_us", optional(row.hasPhases(), median(row.sort_us))},
          {"sweep_us", optional(row.hasPhases(), median(row.sweep_us))},
          {"delta_us", optional(row.hasPhases(), median(row.delta_us))},
          {"cache_us", optional(row.hasPhases(), median(row.cache_us))},
          {"launch_to_finish_us", optional(row.hasPhases(), median(row.launch_to_finish_us))}};
}

// The row's JSON with the GPU columns (null where the finder reports no device work).
nlohmann::json withDeviceColumns(const Row& row, nlohmann::json json) {
  for (std::size_t column = 0; column < std::size(kDeviceColumns); ++column) {
    json[kDeviceColumns[column]] =
        row.hasDeviceWork() ? nlohmann::json(row.deviceMedian(column)) : nlohmann::json(nullptr);
  }
  return json;
}

// What the CSV's columns mean, for its header comment and the JSON.
std::vector<std::string> csvNotes(const BenchOptions& options, const std::string& skipped) {
  std::vector<std::string> notes = {
      (options.inputs.empty()
           ? "scene " + std::to_string(kScene) + ", seed " + std::to_string(options.seed) +
                 ", streams in " + options.streams.string() +
                 " (recorded with bvh and the scene's default substeps)"
           : std::string("streams given by --input (column stream)")) +
          "; warm-up frames " + std::to_string(options.warmup),
      "time per frame: BroadphaseReplay update (setAabb of the boxes that changed since the "
      "frame before, found before the clock starts, as a world knows its awake bodies; with "
      "churn, of every present box) + findPairs "
      "(calculateOverlappingPairs: search and pair-cache update); per repeat (fresh "
      "broadphase) the median of the measured frames; median_us = median over repeats, "
      "min_us/max_us = fastest/slowest repeat",
      "ratio_vs_bvh = median_us / bvh's median_us at the same n in this run (bvh = "
      "btDbvtBroadphase; below 1 is faster than bvh)",
      "pairs_mean: pairs in the cache per measured frame; extra_pairs_mean: cached pairs not in "
      "the exact set (the first exact algorithm of `overlap --list-algos` run at that n) per "
      "measured frame; "
      "missed_pairs: exact "
      "pairs missing from the cache, summed over every frame and repeat; both empty for the "
      "reference itself" +
          std::string(options.grid_check ? "; exact set: gpu/pairs/grid_pair_checker.h's" : ""),
      "churn: share of the boxes destroyed and created each frame (0: none); update_us: the "
      "median frame's update (with churn, its destroyProxy and createProxy); sort_us, sweep_us, "
      "delta_us: our finders' search split (cpusap), cache_us: applying its changes to Bullet's "
      "pair cache, launch_to_finish_us: the finder's launch() to finish()'s return on the host "
      "(our broadphases only); each the median over measured frames, then repeats",
      "GPU finders only (gpubf, gpubf-paper), each the median over measured frames, then "
      "repeats: upload_us, kernels_us, download_us: CUDA events around the upload, the kernels "
      "and the copy back; bytes_to_device, bytes_from_device: bytes over the bus; api_calls: "
      "CUDA runtime calls of launch() and finish(); host_bytes_copied: bytes memcpy'd on the "
      "host; host_entries_sorted: changes sorted on the host (docs/OUTPUTS.md)"};
  if (!skipped.empty()) notes.push_back(skipped);
  return notes;
}

// The workload's stream: the --input file (a file the reader refuses is a
// UsageError naming it), or the recorded scene-4 stream, recorded if missing.
// The scene a workload without --input records (or finds in the cache).
physics::SceneConfig workloadScene(const Workload& workload, const BenchOptions& options) {
  physics::SceneConfig config = physics::SceneConfig::forScene(kScene);
  config.objects = workload.objects;
  config.seed = options.seed;
  return config;
}

CachedStream workloadStream(const Workload& workload, const BenchOptions& options) {
  if (workload.input.empty()) {
    return loadOrRecordStream(options.streams, workloadScene(workload, options),
                              workload.record_frames);
  }
  CachedStream cached;
  cached.path = workload.input;
  const Clock::time_point start = Clock::now();
  try {
    cached.stream =
        workload.read ? std::move(*workload.read) : physics::readAabbStream(workload.input);
  } catch (const physics::AabbStreamError& error) {
    throw UsageError(std::string("--input: ") + error.what());
  }
  cached.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return cached;
}

// Every --input checked before the first is measured: its header and size,
// every box, its frames against --warmup, its boxes against each algorithm
// and --churn.  A file is read through once here and again when measured; a
// stream without a size (a pipe) cannot be read twice, so it is kept.
void checkInputs(std::vector<Workload>& workloads, const BenchOptions& options) {
  // The streams to record must all fit in --streams before the first is
  // recorded (minutes each), not fail when one is written.
  std::uint64_t to_record = 0;
  std::filesystem::path first_missing;
  for (const Workload& workload : workloads) {
    if (!workload.input.empty()) continue;
    const std::filesystem::path cached =
        cachedStreamPath(options.streams, workloadScene(workload, options), workload.record_frames);
    if (std::filesystem::exists(cached)) continue;
    physics::AabbStreamHeader counts;
    counts.objects = workload.objects;
    counts.stored_frames = workload.record_frames + 1;
    to_record += physics::aabbStreamBytes(counts);
    if (first_missing.empty()) first_missing = cached;
  }
  if (to_record > 0) requireFreeSpace(first_missing, to_record, "--streams");
  std::uint64_t pipes_held = 0;  // the pipes read so far, held until the end
  for (Workload& workload : workloads) {
    if (workload.input.empty()) continue;
    physics::AabbStreamHeader header;
    try {
      physics::AabbStreamReader reader(workload.input);
      // The benchmark holds the stream whole: what its header claims must
      // fit the limit before a box is read (a pipe's header included), beside
      // the pipes read before it, which stay held.
      const std::uint64_t bytes = physics::aabbStreamBytes(reader.header());
      requireMemory(
          pipes_held + bytes, options.max_memory_mb,
          "--input " + workload.input.string() + ": " +
              std::to_string(reader.header().stored_frames) + " frames of " +
              std::to_string(reader.header().objects) + " boxes, held whole" +
              (pipes_held > 0 ? " beside " + readableBytes(pipes_held) + " of the pipes before it"
                              : std::string()) +
              ",");
      if (reader.sized()) {
        reader.checkAll();
        header = reader.header();
      } else {
        // Through the reader that read the header: a pipe cannot be reopened.
        workload.read = std::make_shared<physics::AabbStream>(physics::readAabbStream(reader));
        header = *workload.read;
        pipes_held += bytes;
      }
    } catch (const physics::AabbStreamError& error) {
      throw UsageError(std::string("--input: ") + error.what());
    }
    const std::string where = " (--input " + workload.input.string() + ")";
    if (options.warmup >= header.stored_frames) {
      throw UsageError("--warmup " + std::to_string(options.warmup) + ": leaves no frame of " +
                       workload.input.string() + "'s " + std::to_string(header.stored_frames) +
                       " to measure");
    }
    if (options.stream_stats) continue;
    checkWorkloadSize(options, workload.algorithms, header.objects,
                      header.stored_frames - options.warmup, where);
  }
}

void printStreamStatistics(const CachedStream& cached, int warmup) {
  const StreamStatistics statistics = measureStream(cached.stream, std::max(1, warmup));
  // A share of no pairs is no figure: n/a, and a mean over fewer frames says so.
  std::string changed = "n/a (no frame has pairs)";
  if (statistics.frames_with_pairs > 0) {
    char text[64];
    std::snprintf(text, sizeof(text), "%.4f", statistics.changed_pairs);
    changed = text;
    if (statistics.frames_with_pairs < statistics.frames) {
      changed +=
          " (over the " + std::to_string(statistics.frames_with_pairs) + " frames with pairs)";
    }
  }
  std::printf(
      "%s: n=%d, frames %d-%d: pairs per box %.3f, pairs changed per frame %s, boxes moving "
      "per frame %.4f (last frame: %.3f pairs per box, %.4f moving)\n",
      cached.path.c_str(), cached.stream.objects, cached.stream.stored_frames - statistics.frames,
      cached.stream.stored_frames - 1, statistics.pairs_per_box, changed.c_str(),
      statistics.moving_boxes, statistics.last_pairs_per_box, statistics.last_moving_boxes);
}

// The table the benchmark ends with: a row per stream, algorithm and churn.
void printBenchSummary(const BenchOptions& options, const std::vector<Row>& rows) {
  const bool churned = !options.churn.empty();
  const bool inputs = !options.inputs.empty();
  std::vector<std::string> header = {"n", "algorithm"};
  if (inputs) header.push_back("stream");
  if (churned) header.push_back("churn");
  for (const char* column : {"median us", "fastest", "slowest", "vs bvh", "pairs", "missed"}) {
    header.emplace_back(column);
  }
  std::vector<std::vector<std::string>> table = {header};
  for (const Row& row : rows) {
    const auto [fastest, slowest] =
        std::minmax_element(row.repeat_medians_us.begin(), row.repeat_medians_us.end());
    std::vector<std::string> cells = {std::to_string(row.objects), row.algorithm};
    if (inputs) cells.push_back(std::filesystem::path(row.stream).filename().string());
    if (churned) cells.push_back(exactNumber(row.churn));
    for (const std::string& cell :
         {fixed(row.medianUs(), 1), fixed(*fastest, 1), fixed(*slowest, 1),
          row.ratio_vs_bvh ? fixed(*row.ratio_vs_bvh, 3) : std::string("-"),
          fixed(row.pairsMean(), 1), row.checked() ? std::to_string(row.missed) : "-"}) {
      cells.push_back(cell);
    }
    table.push_back(std::move(cells));
  }
  printSummary(options.quiet,
               std::string(kProgram) + ": a frame's update + search + pair cache in us, the " +
                   "median over " + counted(options.repeats, "repeat") +
                   " of each one's median frame (fastest, slowest: of the repeats)",
               alignedTable(table));
}

int run(const BenchOptions& options, const std::string& command) {
  std::string skipped;
  std::vector<Workload> workloads = planWorkloads(options, skipped);
  std::vector<std::filesystem::path> outputs;
  if (!options.record_only && !options.stream_stats) {
    outputs = prepareOutputFiles(options.out, {".csv", ".json"}, "--out");
    refuseOutputsOverInputs(outputs, "--out", options.inputs, "--input");
  }
  if (options.inputs.empty()) prepareOutputDirectory(options.streams, "--streams");
  checkInputs(workloads, options);
  if (!skipped.empty() && !options.record_only && !options.stream_stats) {
    std::fprintf(stderr, "%s: %s\n", kProgram, skipped.c_str());
  }

  const Clock::time_point start = Clock::now();
  std::vector<Row> rows;
  nlohmann::json streams = nlohmann::json::array();
  for (const Workload& workload : workloads) {
    const CachedStream cached = workloadStream(workload, options);
    std::fprintf(stderr, "%s: n=%d: %s %s in %.1f s\n", kProgram, cached.stream.objects,
                 cached.recorded ? "recorded" : "read", oneLine(cached.path.string()).c_str(),
                 cached.seconds);
    streams.push_back({{"n", cached.stream.objects},
                       {"path", cached.path.string()},
                       {"recorded_frames", cached.stream.stored_frames - 1},
                       {"recorded", cached.recorded},
                       {"seconds", cached.seconds}});
    if (options.stream_stats) {
      printStreamStatistics(cached, options.warmup);
      continue;
    }
    if (options.record_only) continue;
    const std::vector<Row> measured = measure(workload, cached.stream, options, start);
    rows.insert(rows.end(), measured.begin(), measured.end());
  }
  if (options.record_only || options.stream_stats) return 0;

  const std::vector<std::string> notes = csvNotes(options, skipped);

  nlohmann::json json = {
      {"machine", machineInfo()},
      {"command", command},
      {"scene", options.inputs.empty() ? nlohmann::json(kScene) : nlohmann::json(nullptr)},
      {"seed", options.seed},
      {"warmup", options.warmup},
      {"repeats", options.repeats},
      {"notes", notes},
      {"streams", streams},
      {"run_seconds", std::chrono::duration<double>(Clock::now() - start).count()},
      {"rows", nlohmann::json::array()}};
  for (const Row& row : rows) json["rows"].push_back(withDeviceColumns(row, rowJson(row)));
  const std::filesystem::path& csv_path = outputs[0];
  const std::filesystem::path& json_path = outputs[1];
  // Both or neither: each is finished, then a signal that came meanwhile
  // stops the run before either is published.
  overlap::OutputFile csv(csv_path);
  overlap::OutputFile json_file(json_path);
  csv.write(csvText(rows, command, notes));
  // A name may hold any bytes: one that is not UTF-8 is written as U+FFFD
  // (nlohmann's default throws, and only after the whole run).
  json_file.write(json.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + '\n');
  csv.finish();
  json_file.finish();
  stopIfInterrupted("the publication of the outputs");
  csv.publish();
  json_file.publish();
  std::fprintf(stderr, "%s: wrote %s and %s\n", kProgram, oneLine(csv_path.string()).c_str(),
               oneLine(json_path.string()).c_str());
  printBenchSummary(options, rows);

  const std::vector<std::string> failed = failures(rows);
  for (const std::string& failure : failed) {
    std::fprintf(stderr, "%s: FAIL %s\n", kProgram, failure.c_str());
  }
  return failed.empty() ? 0 : 1;
}

}  // namespace
}  // namespace overlap::engine

int main(int argc, char** argv) {
  overlap::holdStandardStreams();  // first: before anything opens a file
  using namespace overlap::engine;
  return startProgram(kProgram, [&] {
    CLI::App app{"Broadphase time per frame on recorded scene-4 AABB streams", kProgram};
    app.footer(
        "cpusap's results (docs/results/broadphase_cpusap.md): "
        "scripts/cpusap_table.py --streams DIR runs this with --objects "
        "500,1250,2000,2750,3500,10000,30000 --algos sap,bvh,cpubf,cpusap --big-objects 100000 "
        "--big-algos cpubf,cpusap --repeats 5 and records the load average.");
    BenchOptions options;
    addBenchOptions(app, options);
    overlap::catchInterrupts();
    return runProgram(kProgram, app, [&] {
      app.parse(argc, argv);
      refuseIgnoredOptions(app);
      try {
        return run(options, quotedCommand(argc, argv));
      } catch (const overlap::physics::AabbStreamError& error) {  // a corrupt cached stream, named
        throw UsageError(std::string("bad cached stream: ") + error.what());
      }
    });
  });
}
