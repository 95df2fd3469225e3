// How the `overlap` subcommands fail (docs/CLI.md, "Exit codes").
//
// A UsageError is the user's input being wrong (an option, a value, a file):
// main() prints it as one line and exits with code 2, before any work starts.
// Anything else thrown is a failure while working and exits with code 1
// (OutputError: an output that could not be written, named).
// gpu/base/interrupt.h's Interrupted exits 128 + the signal.  Either way
// nothing half-written is left behind: outputs go through
// gpu/base/output_file.h.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "gpu/base/output_file.h"

namespace overlap::engine {

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Checks that `dir` can hold outputs (outputFolderProblem; it is created
// when the first output opens); throws UsageError naming the option and the
// path if it cannot.  Creates nothing.
void prepareOutputDirectory(const std::filesystem::path& dir, std::string_view option);

// The same for a file to be written (outputFileProblem): an empty
// name, a folder, an unwritable folder are UsageErrors.
void prepareOutputFile(const std::filesystem::path& file, std::string_view option);

// Throws UsageError naming the option when `file`'s folder has less free
// space than `bytes` (a regular file or a new name; nothing for a device or
// FIFO, which stores nothing).  The old file stays until the new one is
// whole, so the new one needs all of `bytes`.
void requireFreeSpace(const std::filesystem::path& file, std::uint64_t bytes,
                      std::string_view option);

// "3.2 GB": a size a user reads at a glance (decimal units).
std::string readableBytes(std::uint64_t bytes);

// The files `prefix` + each suffix ("--out results" -> results.csv,
// results.json), each checked as above; the prefix itself must name a file
// ("", ".", "dir/" and "/" are UsageErrors), and not a device, FIFO or
// socket (/dev/null: the files would be made beside it).
std::vector<std::filesystem::path> prepareOutputFiles(const std::filesystem::path& prefix,
                                                      const std::vector<std::string>& suffixes,
                                                      std::string_view option);

// The same for one output of a run's folder (OutputFolder::declare): also a
// UsageError when another output of the run is that file.
void declareOutput(OutputFolder& outputs, const std::filesystem::path& file,
                   std::string_view option);

// `message` on one line: newline, carriage return and every other control
// character written as an escape (\n, \r, \xNN).  Every message that names
// a path the user gave goes through it (the errors here, the lines naming
// what a command wrote).
std::string oneLine(std::string_view message);

// "--size": an option's name as the user typed it, hidden options included.
std::string optionName(const CLI::Option* option);

// Throws UsageError naming both options when both were given: they
// conflict, or the first would be ignored (`why` says which).
void refuseTogether(const CLI::Option* first, const CLI::Option* second, std::string_view why);

// The whole of a program's main() once its options are added, shared by
// `overlap` and the benchmark: runs `body` (parsing included) and turns what
// it throws into the exit code and one line on stderr, "PROGRAM: ...":
// --help and --version print and exit 0; a ParseError or UsageError exits
// 2 (an option given twice says so in plain words); Interrupted exits 128 +
// the signal; running out of memory (std::bad_alloc) exits 1 saying so;
// anything else exits 1.  Control characters in a message are
// escaped (a value holding a newline stays on the one line).  Standard
// output is flushed last: a failed write there (`> /dev/full`) exits 1
// naming it, whatever printed it.
int runProgram(const char* program, CLI::App& app, const std::function<int()>& body);

}  // namespace overlap::engine
