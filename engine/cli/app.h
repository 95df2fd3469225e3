// The `overlap` command line as a library: addCommands() registers every
// subcommand on an app, runCommandLine() is the whole of main(): it parses,
// runs the chosen subcommand and maps what went wrong to an exit code
// (engine/program/program_runner.h): 0 done, 1 failed while working, 2 bad input.
// Tests and the option-parser fuzz target build the same app main() runs.
#pragma once

#include <CLI/CLI.hpp>

namespace overlap::engine {

// Every subcommand engine/cli/commands.h declares; one of them is required.
void addCommands(CLI::App& app);

int runCommandLine(int argc, char** argv);

}  // namespace overlap::engine
