// The whole of a program's main() once its options are added, shared by
// `overlap` and the broadphase benchmark: what a failure prints and the exit
// code it gives (engine/program/usage_error.h says which failure is which).
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <string_view>

namespace overlap::engine {

// Runs `body` (parsing included) and turns what it throws into the exit
// code and one line on stderr, "PROGRAM: ...": --help and --version print
// and exit 0; a ParseError or UsageError exits 2 (an option given twice says
// so in plain words); Interrupted exits 128 + the signal; running out of
// memory (std::bad_alloc) exits 1 saying so; anything else exits 1.
// Control characters in a message are escaped (a value holding a newline
// stays on the one line).  Standard output is flushed last: a failed write
// there (`> /dev/full`) exits 1 naming it, whatever printed it.
int runProgram(const char* program, CLI::App& app, const std::function<int()>& body);

// The whole of main() after holdStandardStreams(): `program_main` builds the
// command line and calls runProgram.  An allocation that fails before
// runProgram's handlers are in place (while CLI11 adds the options, at a
// `ulimit -v` just above what the libraries need) exits 1 with one line
// saying so, written without allocating, not by SIGABRT.
int startProgram(const char* program, const std::function<int()>& program_main) noexcept;

// `message` on one line: newline, carriage return and every other control
// character written as an escape (\n, \r, \xNN).  Every message that names
// a path the user gave goes through it (the errors, the lines naming what a
// command wrote).
std::string oneLine(std::string_view message);

}  // namespace overlap::engine
