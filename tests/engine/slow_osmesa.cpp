// A stand-in libOSMesa.so.8 whose loading takes half a minute (it marks the
// file named by OVERLAP_SLOW_OSMESA_MARK when it starts) and which then has
// none of OSMesa's entry points: the renderer's start, slow, for the test of
// a stop signal that comes during it (cli_signals_test.cpp).
#include <fcntl.h>
#include <unistd.h>

#include <cstdlib>

namespace {

struct SlowStart {
  SlowStart() {
    if (const char* mark = std::getenv("OVERLAP_SLOW_OSMESA_MARK"); mark != nullptr) {
      const int fd = ::open(mark, O_WRONLY | O_CREAT | O_CLOEXEC, 0600);
      if (fd >= 0) ::close(fd);
    }
    ::sleep(30);
  }
} slow_start;

}  // namespace
