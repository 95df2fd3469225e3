// How the programs of engine/ (`overlap` and the broadphase benchmark) fail
// (docs/CLI.md, "Exit codes").
//
// A UsageError is the user's input being wrong (an option, a value, a file):
// the program runner (engine/program/program_runner.h) prints it as one line
// and exits with code 2, before any work starts.  Anything else thrown is a
// failure while working and exits with code 1 (OutputError: an output that
// could not be written, named).  gpu/base/interrupt.h's Interrupted exits
// 128 + the signal.  Either way nothing half-written is left behind: outputs
// go through gpu/base/output_file.h.
#pragma once

#include <stdexcept>

namespace overlap::engine {

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace overlap::engine
