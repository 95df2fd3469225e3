// The three standard descriptors at a program's start (docs/CLI.md,
// "Outputs").  A program started with fd 0, 1 or 2 closed (`2>&-`) would
// give that number to the first file it opens, and its messages (stderr)
// or its CSV rows (stdout) would land in that file: a WAV, a stream.
//
// Rules:
//   * holdStandardStreams() is the first thing every program's main()
//     does, before anything can open a file; it is called once.
//   * A closed 0, 1 or 2 is given /dev/null, opened so that it keeps
//     behaving as the closed descriptor did: 1 and 2 read-only, 0
//     write-only.  A write to a closed stdout still fails (EBADF, the exit 1
//     of writeStandardOutput()), a message to a closed stderr is still
//     lost, a read of a closed stdin still fails; but no file the program
//     opens can take one of the three numbers.
//   * An open descriptor is left as it is.  If /dev/null cannot be opened
//     (a chroot without it, no descriptor left), the program exits 127 at
//     once, writing nothing: there is nowhere safe to write.
//   * Every message goes to standard error through writeMessage(), which
//     holdStandardStreams() also gives std::cerr and stdio's stderr.  A message never
//     holds a stop: a terminal stopped with Ctrl-S, or a reader of stderr
//     that does not read, blocks a write, and the stop's own line would
//     then never be written and the process never end.  So a pipe, FIFO,
//     socket or terminal is written once poll() says it has room, looking
//     for a stop every tenth of a second, and once a stop signal has come
//     (interrupt.h) the messages wait for room at most a second in all,
//     on every thread together; what does not fit is dropped.  A standard
//     error no write can reach (read-only, a listening socket) drops each
//     message at once, as a failed write does.
//     Async-signal-safe: progress lines are written from a signal handler.
// Plain POSIX: no Bullet here.
#pragma once

#include <cstddef>

namespace overlap {

// Gives every closed standard descriptor /dev/null, and std::cerr
// writeMessage() (see above).
void holdStandardStreams();

// Writes `size` bytes of a message to standard error (see above); a write
// that fails drops the message: there is nowhere else to say so.
void writeMessage(const char* bytes, std::size_t size);

}  // namespace overlap
