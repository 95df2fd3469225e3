// overlap: the demo engine's one executable.  See docs/USAGE.md for the
// subcommands; `overlap SUBCOMMAND --help` lists each one's options.
#include "engine/cli/app.h"

int main(int argc, char** argv) {
  return overlap::engine::runCommandLine(argc, argv);
}
