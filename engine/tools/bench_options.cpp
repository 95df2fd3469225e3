#include "engine/tools/bench_options.h"

#include <sys/stat.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <set>
#include <string>
#include <string_view>

#include "engine/program/list_options.h"
#include "engine/program/memory_bound.h"
#include "engine/program/number_options.h"
#include "engine/program/option_conflicts.h"
#include "engine/program/scene_options.h"
#include "engine/program/summary_output.h"

namespace overlap::engine {
namespace {

// One argument as a POSIX shell reads it back, on one line: as it is when
// plain, else in single quotes, or as $'...' when it holds a control
// character (a newline in a path).
std::string shellQuoted(const std::string& argument) {
  constexpr std::string_view kPlain =
      "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_./=,:+@%";
  if (!argument.empty() && argument.find_first_not_of(kPlain) == std::string::npos) {
    return argument;
  }
  const bool control = std::any_of(argument.begin(), argument.end(),
                                   [](char c) { return static_cast<unsigned char>(c) < 0x20; });
  std::string quoted = control ? "$'" : "'";
  for (const char c : argument) {
    if (!control) {
      quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
    } else if (c == '\'' || c == '\\') {
      quoted += std::string("\\") + c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char escaped[8];
      std::snprintf(escaped, sizeof(escaped), "\\x%02x", static_cast<unsigned char>(c));
      quoted += escaped;
    } else {
      quoted += c;
    }
  }
  return quoted + '\'';
}

}  // namespace

std::string quotedCommand(int argc, char** argv) {
  std::string command = "build/" + std::filesystem::path(argv[0]).filename().string();
  for (int i = 1; i < argc; ++i) command += ' ' + shellQuoted(argv[i]);
  return command;
}

void addBenchOptions(CLI::App& app, BenchOptions& options) {
  addListOption(app, "--objects,-n", options.objects, wholeNumberIn(0, kMostObjects),
                "box counts for --algos (0: none)");
  addListOption(app, "--algos", options.algorithms, broadphaseNameCheck(),
                "broadphases run at each of --objects");
  addListOption(app, "--big-objects", options.big_objects, wholeNumberIn(0, kMostObjects),
                "box counts for --big-algos (0: none)");
  addListOption(app, "--big-algos", options.big_algorithms, broadphaseNameCheck(),
                "broadphases run at each of --big-objects");
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
  addListOption(app, "--churn", options.churn, realNumberIn(0.0, 0.25, true),
                "also replay with this share of the boxes destroyed and as many created every "
                "frame (e.g. 0.01,0.1; at least one box over the measured frames)");
  addMaxMemoryOption(app, options.max_memory_mb);
  app.add_flag("--stream-stats", options.stream_stats,
               "print each --input's pairs per box, pairs changed and boxes moved per frame "
               "(after --warmup), and stop");
  addQuietFlag(app, options.quiet);
}

void refuseIgnoredOptions(const CLI::App& app) {
  const auto refuse = [&app](const char* mode, std::vector<const char*> ignored,
                             const std::string& why) {
    for (const char* name : ignored) {
      refuseTogether(app.get_option(name), app.get_option(mode), why);
    }
  };
  refuse("--record-only",
         {"--input", "--algos", "--big-algos", "--grid-check", "--churn", "--repeats", "--out",
          "--stream-stats"},
         "--record-only records the missing streams and stops, so the first would be ignored");
  refuse("--input",
         {"--objects", "--big-objects", "--big-algos", "--streams", "--record-frames",
          "--big-record-frames"},
         "--input replays the given streams instead of recorded ones, so the first would be "
         "ignored");
  refuse("--stream-stats",
         {"--algos", "--big-algos", "--grid-check", "--churn", "--repeats", "--out"},
         "--stream-stats prints each stream's figures and stops, so the first would be ignored");
  // The seed makes scene 4 and picks --churn's boxes: with --input and no
  // churn, nothing reads it.
  if (app.get_option("--churn")->count() == 0) {
    refuse("--input", {"--seed"},
           "--input replays the given streams and, without --churn, nothing is random, so the "
           "first would be ignored");
  }
  // One stream given twice would be measured twice, as two rows: a file is
  // known by its device and inode however reached (a link, a hard link,
  // another spelling), anything else by its resolved name.
  std::set<std::string> inputs;
  for (const std::string& input : app.get_option("--input")->as<std::vector<std::string>>()) {
    struct stat info {};
    std::string key;
    if (::stat(input.c_str(), &info) == 0 && S_ISREG(info.st_mode)) {
      key = std::to_string(info.st_dev) + ":" + std::to_string(info.st_ino);
    } else {
      std::error_code error;
      const std::filesystem::path file = std::filesystem::weakly_canonical(input, error);
      key = error ? input : file.string();
    }
    if (!inputs.insert(key).second) {
      throw UsageError("--input " + input + ": given twice (the same file); give each stream once");
    }
  }
}

}  // namespace overlap::engine
