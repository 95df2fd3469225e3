#include "gpu/base/standard_streams.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <initializer_list>

namespace overlap {

void holdStandardStreams() {
  // In order: open() returns the lowest free number, so each /dev/null
  // lands on the descriptor it is meant for once the lower ones are held.
  for (const int fd : {STDIN_FILENO, STDOUT_FILENO, STDERR_FILENO}) {
    if (::fcntl(fd, F_GETFD) != -1 || errno != EBADF) continue;
    const int flags = fd == STDIN_FILENO ? O_WRONLY : O_RDONLY;  // fails as the closed one did
    const int opened = ::open("/dev/null", flags);  // no O_CLOEXEC: a child inherits it too
    if (opened != fd) ::_exit(127);
  }
}

}  // namespace overlap
