// libFuzzer target: readAabbStream on arbitrary bytes.  The reader must
// either throw AabbStreamError or hand out a stream that keeps every promise
// of aabb_stream.h; anything else (another exception, a crash, a sanitizer
// report) is a finding.  The bytes go through a memfd, so the reader opens a
// real file by path, as `overlap pairs --input` does, without disk traffic;
// then through a pipe (a stream without a size, read frame by frame), which
// must give the same stream or also be refused.
#include <sys/mman.h>
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <thread>

#include "physics/aabb_stream.h"

namespace {

void require(bool ok, const char* promise) {
  if (!ok) {
    std::fprintf(stderr, "readAabbStream broke its promise: %s\n", promise);
    std::abort();
  }
}

bool wellFormed(const overlap::physics::Aabb& box) {
  for (int axis = 0; axis < 3; ++axis) {
    if (!std::isfinite(box.min[axis]) || !std::isfinite(box.max[axis])) return false;
    if (box.min[axis] > box.max[axis]) return false;
  }
  return true;
}

std::optional<overlap::physics::AabbStream> readOrRefuse(const std::string& path) {
  try {
    return overlap::physics::readAabbStream(path);
  } catch (const overlap::physics::AabbStreamError&) {
    return std::nullopt;  // rejected with a message: what a bad stream should get
  }
}

// The same bytes read from a pipe.
std::optional<overlap::physics::AabbStream> readThroughAPipe(const std::uint8_t* data,
                                                             std::size_t size) {
  static const bool ignoring_sigpipe = std::signal(SIGPIPE, SIG_IGN) != SIG_ERR;
  int ends[2];
  if (!ignoring_sigpipe || pipe(ends) != 0) {
    std::perror("fuzz_aabb_stream: pipe");
    std::abort();
  }
  std::thread writer([&] {
    for (std::size_t sent = 0; sent < size;) {
      const ssize_t wrote = write(ends[1], data + sent, size - sent);
      if (wrote <= 0) break;  // the reader stopped early and closed its end
      sent += static_cast<std::size_t>(wrote);
    }
    close(ends[1]);
  });
  std::optional<overlap::physics::AabbStream> stream =
      readOrRefuse("/proc/self/fd/" + std::to_string(ends[0]));
  close(ends[0]);
  writer.join();
  return stream;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const int fd = memfd_create("fuzz.aabbs", 0);
  static const std::string path = "/proc/self/fd/" + std::to_string(fd);
  if (fd < 0 || ftruncate(fd, 0) != 0 || pwrite(fd, data, size, 0) != static_cast<ssize_t>(size)) {
    std::perror("fuzz_aabb_stream: memfd");
    std::abort();
  }
  const std::optional<overlap::physics::AabbStream> read = readOrRefuse(path);
  const std::optional<overlap::physics::AabbStream> piped = readThroughAPipe(data, size);
  require(read.has_value() == piped.has_value(), "a pipe refuses what a file refuses");
  if (!read) return 0;
  const overlap::physics::AabbStream& stream = *read;
  require(piped->boxes.size() == stream.boxes.size() && piped->objects == stream.objects &&
              piped->scene_name == stream.scene_name,
          "a pipe gives the stream a file gives");
  require(stream.objects > 0 && stream.stored_frames > 1, "positive counts");
  require(stream.boxes.size() == static_cast<std::size_t>(stream.objects) *
                                     static_cast<std::size_t>(stream.stored_frames),
          "one box per object and stored frame");
  require(wellFormed(stream.world), "a finite world AABB with min <= max");
  for (const overlap::physics::Aabb& box : stream.boxes) {
    require(wellFormed(box), "finite boxes with min <= max");
  }
  require(stream.frame(stream.stored_frames - 1).size() == static_cast<std::size_t>(stream.objects),
          "every frame holds every object");
  return 0;
}
