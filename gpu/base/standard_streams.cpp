#include "gpu/base/standard_streams.h"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <initializer_list>
#include <iostream>
#include <streambuf>

#include "gpu/base/interrupt.h"

namespace overlap {
namespace {

// std::cerr's buffer: each write goes to writeMessage() at once, unbuffered
// as std::cerr is.
class MessageBuffer : public std::streambuf {
 protected:
  int_type overflow(int_type c) override {
    if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
    const char byte = traits_type::to_char_type(c);
    writeMessage(&byte, 1);
    return c;
  }
  std::streamsize xsputn(const char* bytes, std::streamsize size) override {
    writeMessage(bytes, static_cast<std::size_t>(size));
    return size;
  }
};

// stdio's stderr: a stream whose writes go to writeMessage(), unbuffered.
ssize_t writeCookie(void* /*cookie*/, const char* bytes, std::size_t size) {
  writeMessage(bytes, size);
  return static_cast<ssize_t>(size);
}

}  // namespace

void holdStandardStreams() {
  // In order: open() returns the lowest free number, so each /dev/null
  // lands on the descriptor it is meant for once the lower ones are held.
  for (const int fd : {STDIN_FILENO, STDOUT_FILENO, STDERR_FILENO}) {
    if (::fcntl(fd, F_GETFD) != -1 || errno != EBADF) continue;
    const int flags = fd == STDIN_FILENO ? O_WRONLY : O_RDONLY;  // fails as the closed one did
    const int opened = ::open("/dev/null", flags);  // no O_CLOEXEC: a child inherits it too
    if (opened != fd) ::_exit(127);
  }
  static MessageBuffer messages;  // lives as long as std::cerr may be used
  std::cerr.rdbuf(&messages);
  // glibc's stderr is a variable: fprintf(stderr, ...), ours and the
  // libraries', goes through writeMessage() too.  Kept as it was if the
  // stream cannot be made.
  if (FILE* through = ::fopencookie(nullptr, "w", {nullptr, writeCookie, nullptr, nullptr})) {
    std::setvbuf(through, nullptr, _IONBF, 0);
    stderr = through;
  }
}

void writeMessage(const char* bytes, std::size_t size) {
  constexpr int kMostWaitAfterAStopMs = 1000;
  constexpr int kLookEveryMs = 100;
  int waited_ms = 0;
  while (size > 0) {
    if (pendingInterrupt() != 0) {
      if (waited_ms >= kMostWaitAfterAStopMs) return;
      pollfd room{STDERR_FILENO, POLLOUT, 0};
      const int ready = ::poll(&room, 1, kLookEveryMs);
      if (ready <= 0) {
        waited_ms += kLookEveryMs;
        continue;
      }
    }
    const ssize_t wrote = ::write(STDERR_FILENO, bytes, size);
    if (wrote < 0 && errno == EINTR) continue;
    if (wrote < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      pollfd room{STDERR_FILENO, POLLOUT, 0};
      ::poll(&room, 1, kLookEveryMs);
      if (pendingInterrupt() != 0) waited_ms += kLookEveryMs;
      continue;
    }
    if (wrote <= 0) return;
    bytes += wrote;
    size -= static_cast<std::size_t>(wrote);
  }
}

}  // namespace overlap
