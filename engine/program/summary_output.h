// The summary every subcommand and the benchmark end with
// (engine/runtime/run_summary.h builds its lines), and --quiet, which drops
// it and nothing else: progress, notices, errors and the closing "wrote"
// line stay.  On stderr, as every other message: `pairs` and `latency`
// print their CSV on stdout.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace overlap::engine {

// Registers --quiet on `command`.
void addQuietFlag(CLI::App& command, bool& quiet);

// `title` on one line, then each of `lines` indented by two spaces, unless `quiet`.
void printSummary(bool quiet, const std::string& title, const std::vector<std::string>& lines);

}  // namespace overlap::engine
