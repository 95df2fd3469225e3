// overlap: the demo engine's one executable.  See docs/USAGE.md for the
// subcommands; `overlap SUBCOMMAND --help` lists each one's options.
#include "engine/cli/app.h"
#include "gpu/base/standard_streams.h"

int main(int argc, char** argv) {
  overlap::holdStandardStreams();  // first: before anything opens a file
  return overlap::engine::runCommandLine(argc, argv);
}
