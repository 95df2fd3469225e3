// The one signal path.  SIGINT and SIGTERM only set a flag; every loop over
// frames calls stopIfInterrupted() at each frame boundary, which throws
// Interrupted.  Unwinding removes every temporary (gpu/base/output_file.h)
// and publishes nothing, so the outputs hold what they held before;
// runCommandLine() says so in one line and exits 128 + the signal (130 for
// SIGINT, 143 for SIGTERM).  A second signal before that ends the process at
// once (the handler is reset after the first), leaving only hidden
// temporaries (".NAME.overlap-XXXXXX") beside the untouched outputs.
#pragma once

#include <stdexcept>
#include <string>

namespace overlap::engine {

// what(): the signal's name and where it stopped ("SIGINT at frame 12").
struct Interrupted : std::runtime_error {
  Interrupted(int signal_number, const std::string& where);
  int signal;
};

// Installs the handlers for SIGINT and SIGTERM.
void catchInterrupts();

// Throws Interrupted if a signal arrived; `where` (e.g. "frame 12 of 300")
// goes into the message.
void stopIfInterrupted(const std::string& where);

}  // namespace overlap::engine
