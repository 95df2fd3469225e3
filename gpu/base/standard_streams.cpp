#include "gpu/base/standard_streams.h"

#include <fcntl.h>
#include <limits.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
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

// The time messages have waited for room since a stop came, all together:
// once a second, every later message is dropped at once (progress lines
// come from a timer's signal each second, and would each wait anew).
std::atomic<int> waited_after_a_stop_ms{0};

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
  constexpr int kMostWaitAfterAStopMs = 1000;  // for all the messages, on every thread
  constexpr int kLookEveryMs = 100;
  // What waits for room, and whose poll() says when there is: a pipe, FIFO,
  // socket or terminal, written a pipe buffer at a time once there is room.
  // A standard error no write can reach (read-only, as holdStandardStreams
  // leaves a closed one; a listening socket) drops the message at once: its
  // poll() would never say there is room.
  const int flags = ::fcntl(STDERR_FILENO, F_GETFL);
  int listening = 0;
  socklen_t length = sizeof(listening);
  if (flags < 0 || (flags & O_ACCMODE) == O_RDONLY ||
      (::getsockopt(STDERR_FILENO, SOL_SOCKET, SO_ACCEPTCONN, &listening, &length) == 0 &&
       listening != 0)) {
    return;
  }
  struct stat info {};
  const bool may_wait = ::fstat(STDERR_FILENO, &info) == 0 &&
                        (S_ISFIFO(info.st_mode) || S_ISSOCK(info.st_mode) ||
                         (S_ISCHR(info.st_mode) && ::isatty(STDERR_FILENO) == 1));
  while (size > 0) {
    const bool stopping = pendingInterrupt() != 0;
    if (stopping && waited_after_a_stop_ms.load() >= kMostWaitAfterAStopMs) return;
    if (may_wait || stopping) {
      pollfd room{STDERR_FILENO, POLLOUT, 0};
      if (::poll(&room, 1, kLookEveryMs) <= 0) {
        if (pendingInterrupt() != 0) waited_after_a_stop_ms.fetch_add(kLookEveryMs);
        continue;
      }
    }
    const std::size_t chunk = may_wait ? std::min<std::size_t>(size, PIPE_BUF) : size;
    const ssize_t wrote = ::write(STDERR_FILENO, bytes, chunk);
    if (wrote < 0 && errno == EINTR) continue;
    if (wrote < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {  // non-blocking: wait, not spin
      pollfd room{STDERR_FILENO, POLLOUT, 0};
      if (::poll(&room, 1, kLookEveryMs) <= 0 && pendingInterrupt() != 0) {
        waited_after_a_stop_ms.fetch_add(kLookEveryMs);
      }
      continue;
    }
    if (wrote <= 0) return;
    bytes += wrote;
    size -= static_cast<std::size_t>(wrote);
  }
}

}  // namespace overlap
