#include "engine/cli/app.h"

#include <algorithm>
#include <string>
#include <string_view>
#include <vector>

#include "engine/cli/algorithm_list.h"
#include "engine/cli/commands.h"
#include "engine/program/program_runner.h"
#include "engine/program/usage_error.h"
#include "gpu/base/interrupt.h"
#include "gpu/base/shown_value.h"
#include "overlap_build_info.h"

namespace overlap::engine {

void addCommands(CLI::App& app) {
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("overlap ") + OVERLAP_VERSION + " (git " +
                                        OVERLAP_GIT_COMMIT + ", " + OVERLAP_BUILD_TYPE + ")");
  app.footer(
      "Start with `overlap run` (a one-minute demo into ./out); "
      "`overlap SUBCOMMAND --help` lists its options with their defaults and an example.");
  addListAlgosFlag(app);
  addRunCommand(app);
  addRecordCommand(app);
  addPairsCommand(app);
  addGenerateCommand(app);
  addCaptureCommand(app);
  addLatencyCommand(app);
}

namespace {

// Refuses a first word that names no subcommand, listing them (CLI11 would
// say only that one is required).
void requireKnownSubcommand(const CLI::App& app, int argc, char** argv) {
  std::string names;
  bool known = false;
  for (const CLI::App* command : app.get_subcommands([](const CLI::App*) { return true; })) {
    names += (names.empty() ? "" : ", ") + command->get_name();
    known = known || (argc > 1 && command->get_name() == argv[1]);
  }
  if (argc < 2) throw UsageError("a subcommand is required: " + names + " (see --help)");
  if (argv[1][0] != '-' && !known) {
    throw UsageError("unknown subcommand '" + shownValue(argv[1]) + "'; the subcommands are " +
                     names + " (see --help)");
  }
}

// --list-algos prints and exits as soon as it is parsed: anything beside it
// but --json would be ignored, so it is refused.
void refuseWordsBesideListAlgos(int argc, char** argv) {
  const std::vector<std::string_view> words(argv + 1, argv + argc);
  if (std::find(words.begin(), words.end(), "--list-algos") == words.end()) return;
  for (const std::string_view word : words) {
    if (word != "--list-algos" && word != "--json") {
      throw UsageError("--list-algos takes nothing but --json; '" + shownValue(word) +
                       "' would be ignored");
    }
  }
}

}  // namespace

int runCommandLine(int argc, char** argv) {
  return startProgram("overlap", [&] {
    CLI::App app{"Overlap: GPU brute-force broadphase in Bullet (Serpa & Rodrigues, SBGames 2014)",
                 "overlap"};
    addCommands(app);
    catchInterrupts();
    return runProgram("overlap", app, [&] {
      requireKnownSubcommand(app, argc, argv);
      refuseWordsBesideListAlgos(argc, argv);
      app.parse(argc, argv);
      return 0;
    });
  });
}

}  // namespace overlap::engine
