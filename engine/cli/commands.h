// The `overlap` subcommands.  Each add*Command registers one subcommand on the
// app with its options and the callback that runs it; runCommandLine() (engine/cli/app.h) only
// parses and maps errors to exit codes (engine/program/program_runner.h).
#pragma once

#include <CLI/CLI.hpp>

namespace overlap::engine {

void addRunCommand(CLI::App& app);
void addRecordCommand(CLI::App& app);
void addPairsCommand(CLI::App& app);
void addGenerateCommand(CLI::App& app);
void addCaptureCommand(CLI::App& app);
void addLatencyCommand(CLI::App& app);

}  // namespace overlap::engine
