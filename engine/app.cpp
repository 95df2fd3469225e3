#include "engine/app.h"

#include <cstdio>
#include <exception>
#include <string>

#include "engine/cli_errors.h"
#include "engine/commands.h"
#include "overlap_build_info.h"

namespace overlap::engine {

void addCommands(CLI::App& app) {
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("overlap ") + OVERLAP_VERSION + " (git " +
                                        OVERLAP_GIT_COMMIT + ", " + OVERLAP_BUILD_TYPE + ")");
  app.footer(
      "Start with `overlap run` (a one-minute demo into ./out); "
      "`overlap SUBCOMMAND --help` lists its options with their defaults and an example.");
  addRunCommand(app);
  addRecordCommand(app);
  addPairsCommand(app);
  addGenerateCommand(app);
  addCaptureCommand(app);
  addLatencyCommand(app);
}

int runCommandLine(int argc, char** argv) {
  CLI::App app{"Overlap: GPU brute-force broadphase in Bullet (Serpa & Rodrigues, SBGames 2014)",
               "overlap"};
  addCommands(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& help_or_version) {
    return app.exit(help_or_version);
  } catch (const CLI::ParseError& error) {
    std::fprintf(stderr, "overlap: %s (see --help)\n", error.what());
    return 2;
  } catch (const UsageError& error) {
    std::fprintf(stderr, "overlap: %s\n", error.what());
    return 2;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "overlap: error: %s\n", error.what());
    return 1;
  }
  return 0;
}

}  // namespace overlap::engine
