// overlap_bench_broadphase's command line: its options, the ones a run
// would ignore (refused naming both, docs/CLI.md), and the command as the
// results record it.  The lists go through engine/program/list_options.h.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace overlap::engine {

// What the benchmark runs; the defaults are the recorded scene-4 study.
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
  std::uint64_t max_memory_mb = 0;  // 0: engine/program/memory_bound.h's default
  bool quiet = false;               // no summary table at the end
};

void addBenchOptions(CLI::App& app, BenchOptions& options);

// Throws UsageError naming both options when one is given to a run that
// would ignore it: what --input, --stream-stats and --record-only leave out
// (--seed with --input and no --churn); and naming the file when one
// --input is given twice.
void refuseIgnoredOptions(const CLI::App& app);

// The command line as it reruns from the repository's top, on one line:
// the executable as the build puts it (build/overlap_bench_broadphase), each
// argument as a POSIX shell reads it back ($'...' for a control character).
std::string quotedCommand(int argc, char** argv);

}  // namespace overlap::engine
