#include "engine/app.h"

#include <cstdio>
#include <exception>
#include <new>
#include <string>

#include "engine/algorithm_list.h"
#include "engine/cli_errors.h"
#include "engine/commands.h"
#include "engine/memory_bound.h"
#include "gpu/base/interrupt.h"
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
    throw UsageError("unknown subcommand '" + std::string(argv[1]) + "'; the subcommands are " +
                     names + " (see --help)");
  }
}

}  // namespace

int runCommandLine(int argc, char** argv) {
  CLI::App app{"Overlap: GPU brute-force broadphase in Bullet (Serpa & Rodrigues, SBGames 2014)",
               "overlap"};
  addCommands(app);
  catchInterrupts();
  try {
    requireKnownSubcommand(app, argc, argv);
    app.parse(argc, argv);
  } catch (const CLI::Success& help_or_version) {
    return app.exit(help_or_version);
  } catch (const CLI::ParseError& error) {
    std::fprintf(stderr, "overlap: %s (see --help)\n", error.what());
    return 2;
  } catch (const UsageError& error) {
    std::fprintf(stderr, "overlap: %s\n", error.what());
    return 2;
  } catch (const Interrupted& stop) {
    return reportInterrupted("overlap", stop);
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "overlap: %s\n", outOfMemoryMessage().c_str());
    return 1;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "overlap: error: %s\n", error.what());
    return 1;
  }
  return 0;
}

}  // namespace overlap::engine
