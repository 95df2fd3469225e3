// overlap_bench_broadphase: project issue 3's broadphase benchmark.
//
// Every broadphase replays the same recorded scene-4 AABB streams
// (engine/recorded_streams.h) through physics::BroadphaseReplay, in one process,
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
// first exact algorithm (in the catalogue's order, physics/broadphase_factory.h)
// run at that n: an exact algorithm must match it, one that is not must hold
// all of it and may hold extra pairs.  A mismatch or a missed pair makes
// the run fail (exit 1) after it has written its results.
//
// GPU algorithms run only where a CUDA device is present; elsewhere they are
// skipped with a note, never measured as their CPU fallback.
//
// --input FILE.aabbs... replays those streams (any .aabbs, Broadmark's own
// included) instead of the recorded scene-4 ones, each with every --algos
// algorithm; --grid-check takes the exact set from gpu/grid_pair_checker.h,
// an exact finder that shares no code with cpusap, so every exact algorithm
// is checked (fit for 10^5-10^6 boxes, where cpubf is too slow); --churn
// adds, for each share s, rows in which about s of the boxes are destroyed
// and s created every frame (engine/bench_replay.h); --stream-stats prints
// what each input asks of a broadphase (engine/stream_statistics.h) and stops.
// Our broadphases' frames are split into update (setAabb), sort, sweep,
// delta and Bullet's pair-cache update.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "engine/bench_replay.h"
#include "engine/cli_errors.h"
#include "engine/machine_info.h"
#include "engine/number_options.h"
#include "engine/recorded_streams.h"
#include "engine/scene_options.h"
#include "engine/statistics.h"
#include "engine/stream_statistics.h"
#include "gpu/base/output_file.h"
#include "gpu/pair_finder.h"
#include "physics/broadphase_factory.h"
#include "physics/broadphase_replay.h"

namespace overlap::engine {
namespace {

using Clock = std::chrono::steady_clock;
using physics::PairList;

constexpr const char* kProgram = "overlap_bench_broadphase";
constexpr int kScene = 4;

struct BenchOptions {
  std::vector<int> objects{500, 1250, 2000, 2750, 3500};
  std::vector<std::string> algorithms{"bf",     "sap",   "bvh",         "cpubf",
                                      "cpusap", "gpubf", "gpubf-paper", "gpusap"};
  std::vector<int> big_objects{10000, 30000, 100000};
  std::vector<std::string> big_algorithms{"bvh", "cpubf", "cpusap", "gpubf", "gpusap"};
  std::filesystem::path streams = "out/streams";
  std::filesystem::path out = "out/broadphase";
  std::uint64_t seed = 42;
  int record_frames = 64;
  int big_record_frames = 64;
  int warmup = 8;
  int repeats = 5;
  bool record_only = false;
  std::vector<std::filesystem::path> inputs;
  bool grid_check = false;
  std::vector<double> churn;
  bool stream_stats = false;
};

// One n of the run: its stream's length and the algorithms measured on it.
struct Workload {
  int objects;
  int record_frames;
  std::vector<std::string> algorithms;  // in broadphaseNames() order
  std::filesystem::path input;          // empty: the recorded scene-4 stream
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

// The run's workloads, GPU algorithms dropped (with `skipped` set) when no
// device can run them.  Throws UsageError for an empty or ambiguous plan.
std::vector<Workload> planWorkloads(const BenchOptions& options, std::string& skipped) {
  std::string why;
  const bool have_gpu = gpu::cudaDeviceAvailable(&why);
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
      by_objects.emplace(n, Workload{n, record_frames, runnable(algorithms), {}});
    }
  };
  if (!options.inputs.empty()) {
    std::vector<Workload> inputs;
    for (const std::filesystem::path& input : options.inputs) {
      inputs.push_back(Workload{0, 0, runnable(options.algorithms), input});
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
      replayOnce(stream, options.warmup, options.seed, reference, has_reference, *row);
      char figure[96];
      std::snprintf(figure, sizeof(figure), " %s%s %.1f us", row->algorithm.c_str(),
                    row->churn > 0 ? (" churn " + fixed(row->churn, 3)).c_str() : "",
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
    if (row.churn > 0) where += " with churn " + fixed(row.churn, 3);
    if (isExact(row.algorithm) && row.mismatched_frames > 0) {
      found.push_back(where + ": pair cache differs from " + *row.reference + "'s on " +
                      std::to_string(row.mismatched_frames) + " frames");
    } else if (row.missed > 0) {
      found.push_back(where + ": missed " + std::to_string(row.missed) + " overlapping pairs");
    }
  }
  return found;
}

std::string csvText(const std::vector<Row>& rows, const std::string& command,
                    const std::vector<std::string>& notes) {
  std::string csv = "# " + machineSummary() + "; command: " + command + '\n';
  for (const std::string& note : notes) csv += "# " + note + '\n';
  csv +=
      "n,algorithm,frames,repeats,median_us,min_us,max_us,ratio_vs_bvh,pairs_mean,"
      "extra_pairs_mean,missed_pairs,stream,churn,update_us,sort_us,sweep_us,delta_us,cache_us\n";
  for (const Row& row : rows) {
    const auto [fastest, slowest] =
        std::minmax_element(row.repeat_medians_us.begin(), row.repeat_medians_us.end());
    const bool checked = row.checked();
    csv += std::to_string(row.objects) + ',' + row.algorithm + ',' + std::to_string(row.frames) +
           ',' + std::to_string(row.repeats()) + ',' + fixed(row.medianUs(), 1) + ',' +
           fixed(*fastest, 1) + ',' + fixed(*slowest, 1) + ',' +
           (row.ratio_vs_bvh ? fixed(*row.ratio_vs_bvh, 3) : "") + ',' + fixed(row.pairsMean(), 1) +
           ',' + (checked ? fixed(row.extraMean(), 1) : "") + ',' +
           (checked ? std::to_string(row.missed) : "") + ',' + row.stream + ',' +
           fixed(row.churn, 3) + ',' + fixed(median(row.update_us), 1);
    for (const auto* phase : {&row.sort_us, &row.sweep_us, &row.delta_us, &row.cache_us}) {
      csv += ',' + (row.hasPhases() ? fixed(median(*phase), 1) : "");
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
          {"cache_us", optional(row.hasPhases(), median(row.cache_us))}};
}

// The command line as it reruns from the repository's top: the executable as
// the build puts it (build/overlap_bench_broadphase), not this machine's path.
std::string quotedCommand(int argc, char** argv) {
  std::string command;
  for (int i = 0; i < argc; ++i) {
    const std::string argument =
        i == 0 ? "build/" + std::filesystem::path(argv[0]).filename().string() : argv[i];
    if (i > 0) command += ' ';
    const bool plain =
        !argument.empty() && argument.find_first_of(" \t\"'$\\") == std::string::npos;
    command += plain ? argument : '\'' + argument + '\'';
  }
  return command;
}

void addOptions(CLI::App& app, BenchOptions& options) {
  app.add_option("--objects,-n", options.objects, "box counts for --algos (0: none)")
      ->delimiter(',')
      ->check(wholeNumberIn(0, kMostObjects))
      ->capture_default_str();
  app.add_option("--algos", options.algorithms, "broadphases run at each of --objects")
      ->delimiter(',')
      ->check(broadphaseNameCheck())
      ->capture_default_str();
  app.add_option("--big-objects", options.big_objects, "box counts for --big-algos (0: none)")
      ->delimiter(',')
      ->check(wholeNumberIn(0, kMostObjects))
      ->capture_default_str();
  app.add_option("--big-algos", options.big_algorithms, "broadphases run at each of --big-objects")
      ->delimiter(',')
      ->check(broadphaseNameCheck())
      ->capture_default_str();
  app.add_option("--streams", options.streams, "folder of cached .aabbs streams")
      ->capture_default_str();
  app.add_option("--out", options.out, "results: OUT.csv and OUT.json")->capture_default_str();
  app.add_option("--seed", options.seed, "scene 4's seed")
      ->check(seedNumber())
      ->capture_default_str();
  app.add_option("--record-frames", options.record_frames,
                 "frames of each --objects stream (F; F + 1 are replayed)")
      ->check(wholeNumberIn(1, 100'000))
      ->capture_default_str();
  app.add_option("--big-record-frames", options.big_record_frames,
                 "frames of each --big-objects stream")
      ->check(wholeNumberIn(1, 100'000))
      ->capture_default_str();
  app.add_option("--warmup", options.warmup, "first replayed frames left out of the figures")
      ->check(wholeNumberIn(0, 100'000))
      ->capture_default_str();
  app.add_option("--repeats", options.repeats, "replays of each stream per algorithm")
      ->check(wholeNumberIn(1, 1000))
      ->capture_default_str();
  app.add_flag("--record-only", options.record_only,
               "record the missing streams and stop (to record several n in parallel)");
  app.add_option("--input", options.inputs,
                 ".aabbs streams to replay with every --algos algorithm, instead of the recorded "
                 "scene-4 ones (--objects, --big-objects and --streams are then not used)")
      ->check(CLI::ExistingFile);
  app.add_flag("--grid-check", options.grid_check,
               "check every frame against the grid checker's exact pairs (fit for 10^6 boxes)");
  app.add_option("--churn", options.churn,
                 "also replay with this share of the boxes destroyed and as many created every "
                 "frame (e.g. 0.01,0.1)")
      ->delimiter(',')
      ->check(realNumberIn(0.0, 0.25, true));
  app.add_flag("--stream-stats", options.stream_stats,
               "print each --input's pairs per box, pairs changed and boxes moved per frame "
               "(after --warmup), and stop");
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
          std::string(options.grid_check ? "; exact set: gpu/grid_pair_checker.h's" : ""),
      "churn: share of the boxes destroyed and created each frame (0: none); update_us: the "
      "median frame's update (with churn, its destroyProxy and createProxy); sort_us, sweep_us, "
      "delta_us: our finders' search split (cpusap), cache_us: applying its changes to Bullet's "
      "pair cache (our broadphases only); each the median over measured frames, then repeats"};
  if (!skipped.empty()) notes.push_back(skipped);
  return notes;
}

// The workload's stream: the --input file (a file the reader refuses is a
// UsageError naming it), or the recorded scene-4 stream, recorded if missing.
CachedStream workloadStream(const Workload& workload, const BenchOptions& options) {
  if (workload.input.empty()) {
    physics::SceneConfig config = physics::SceneConfig::forScene(kScene);
    config.objects = workload.objects;
    config.seed = options.seed;
    return loadOrRecordStream(options.streams, config, workload.record_frames);
  }
  CachedStream cached;
  cached.path = workload.input;
  const Clock::time_point start = Clock::now();
  try {
    cached.stream = physics::readAabbStream(workload.input);
  } catch (const physics::AabbStreamError& error) {
    throw UsageError(std::string("--input: ") + error.what());
  }
  cached.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (options.warmup >= cached.stream.stored_frames) {
    throw UsageError("--warmup " + std::to_string(options.warmup) + ": leaves no frame of " +
                     workload.input.string() + "'s " + std::to_string(cached.stream.stored_frames) +
                     " to measure");
  }
  return cached;
}

void printStreamStatistics(const CachedStream& cached, int warmup) {
  const StreamStatistics statistics = measureStream(cached.stream, std::max(1, warmup));
  std::printf(
      "%s: n=%d, frames %d-%d: pairs per box %.3f, pairs changed per frame %.4f, boxes moving "
      "per frame %.4f (last frame: %.3f pairs per box, %.4f moving)\n",
      cached.path.c_str(), cached.stream.objects, cached.stream.stored_frames - statistics.frames,
      cached.stream.stored_frames - 1, statistics.pairs_per_box, statistics.changed_pairs,
      statistics.moving_boxes, statistics.last_pairs_per_box, statistics.last_moving_boxes);
}

int run(const BenchOptions& options, const std::string& command) {
  std::string skipped;
  const std::vector<Workload> workloads = planWorkloads(options, skipped);
  if (options.inputs.empty()) prepareOutputDirectory(options.streams, "--streams");
  if (!options.record_only && !options.stream_stats) {
    prepareOutputDirectory(
        options.out.has_parent_path() ? options.out.parent_path() : std::filesystem::path("."),
        "--out");
  }
  if (!skipped.empty() && !options.record_only) {
    std::fprintf(stderr, "%s: %s\n", kProgram, skipped.c_str());
  }

  const Clock::time_point start = Clock::now();
  std::vector<Row> rows;
  nlohmann::json streams = nlohmann::json::array();
  for (const Workload& workload : workloads) {
    const CachedStream cached = workloadStream(workload, options);
    std::fprintf(stderr, "%s: n=%d: %s %s in %.1f s\n", kProgram, cached.stream.objects,
                 cached.recorded ? "recorded" : "read", cached.path.c_str(), cached.seconds);
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
  for (const Row& row : rows) json["rows"].push_back(rowJson(row));
  std::filesystem::path csv_path = options.out, json_path = options.out;
  csv_path += ".csv";
  json_path += ".json";
  writeFileAtomically(csv_path, csvText(rows, command, notes));
  writeFileAtomically(json_path, json.dump(2) + '\n');
  std::fprintf(stderr, "%s: wrote %s and %s\n", kProgram, csv_path.c_str(), json_path.c_str());

  const std::vector<std::string> failed = failures(rows);
  for (const std::string& failure : failed) {
    std::fprintf(stderr, "%s: FAIL %s\n", kProgram, failure.c_str());
  }
  return failed.empty() ? 0 : 1;
}

}  // namespace
}  // namespace overlap::engine

int main(int argc, char** argv) {
  using namespace overlap::engine;
  CLI::App app{"Broadphase time per frame on recorded scene-4 AABB streams (project issue 3)",
               kProgram};
  app.footer(
      "cpusap's results (issue 13, docs/results/broadphase_cpusap.md): "
      "scripts/cpusap_table.py --streams DIR runs this with --objects "
      "500,1250,2000,2750,3500,10000,30000 --algos sap,bvh,cpubf,cpusap --big-objects 100000 "
      "--big-algos cpubf,cpusap --repeats 5 and records the load average.");
  BenchOptions options;
  addOptions(app, options);
  try {
    app.parse(argc, argv);
    return run(options, quotedCommand(argc, argv));
  } catch (const CLI::CallForHelp& help) {
    return app.exit(help);
  } catch (const CLI::ParseError& error) {
    std::fprintf(stderr, "%s: %s (see --help)\n", kProgram, error.what());
    return 2;
  } catch (const UsageError& error) {
    std::fprintf(stderr, "%s: %s\n", kProgram, error.what());
    return 2;
  } catch (const overlap::physics::AabbStreamError& error) {  // a corrupt cached stream, named
    std::fprintf(stderr, "%s: bad cached stream: %s\n", kProgram, error.what());
    return 2;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "%s: error: %s\n", kProgram, error.what());
    return 1;
  }
}
