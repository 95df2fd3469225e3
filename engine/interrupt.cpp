#include "engine/interrupt.h"

#include <csignal>
#include <string>

namespace overlap::engine {
namespace {

volatile std::sig_atomic_t received = 0;

extern "C" void onSignal(int signal_number) {
  received = signal_number;
}

}  // namespace

Interrupted::Interrupted(int signal_number, const std::string& where)
    : std::runtime_error(std::string(signal_number == SIGINT ? "SIGINT" : "SIGTERM") + " at " +
                         where),
      signal(signal_number) {}

void catchInterrupts() {
  struct sigaction action {};
  action.sa_handler = onSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESETHAND;  // a second signal ends the process at once
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

void stopIfInterrupted(const std::string& where) {
  if (received != 0) throw Interrupted(received, where);
}

}  // namespace overlap::engine
