// overlap: the demo engine's one executable.  See README.md for the
// subcommands; `overlap SUBCOMMAND --help` lists each one's options.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>

#include "engine/cli_errors.h"
#include "engine/commands.h"

int main(int argc, char** argv) {
  CLI::App app{"Overlap: GPU brute-force broadphase in Bullet (Serpa & Rodrigues, SBGames 2014)",
               "overlap"};
  app.require_subcommand(1);
  overlap::engine::addRunCommand(app);
  overlap::engine::addRecordCommand(app);
  overlap::engine::addPairsCommand(app);
  overlap::engine::addCaptureCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& help) {
    return app.exit(help);
  } catch (const CLI::CallForAllHelp& help) {
    return app.exit(help);
  } catch (const CLI::ParseError& error) {
    std::fprintf(stderr, "overlap: %s (see --help)\n", error.what());
    return 2;
  } catch (const overlap::engine::UsageError& error) {
    std::fprintf(stderr, "overlap: %s\n", error.what());
    return 2;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "overlap: error: %s\n", error.what());
    return 1;
  }
  return 0;
}
