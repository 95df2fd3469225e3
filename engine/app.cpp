#include "engine/app.h"

#include <cstdio>
#include <exception>

#include "engine/cli_errors.h"
#include "engine/commands.h"

namespace overlap::engine {

void addCommands(CLI::App& app) {
  app.require_subcommand(1);
  addRunCommand(app);
  addRecordCommand(app);
  addPairsCommand(app);
  addCaptureCommand(app);
  addLatencyCommand(app);
}

int runCommandLine(int argc, char** argv) {
  CLI::App app{"Overlap: GPU brute-force broadphase in Bullet (Serpa & Rodrigues, SBGames 2014)",
               "overlap"};
  addCommands(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& help) {
    return app.exit(help);
  } catch (const CLI::CallForAllHelp& help) {
    return app.exit(help);
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
