// libFuzzer target: readAabbStream on arbitrary bytes.  The reader must
// either throw AabbStreamError or hand out a stream that keeps every promise
// of aabb_stream.h; anything else (another exception, a crash, a sanitizer
// report) is a finding.  The bytes go through a memfd, so the reader opens a
// real file by path, as `overlap pairs --input` does, without disk traffic.
#include <sys/mman.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

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

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const int fd = memfd_create("fuzz.aabbs", 0);
  static const std::string path = "/proc/self/fd/" + std::to_string(fd);
  if (fd < 0 || ftruncate(fd, 0) != 0 || pwrite(fd, data, size, 0) != static_cast<ssize_t>(size)) {
    std::perror("fuzz_aabb_stream: memfd");
    std::abort();
  }
  overlap::physics::AabbStream stream;
  try {
    stream = overlap::physics::readAabbStream(path);
  } catch (const overlap::physics::AabbStreamError&) {
    return 0;  // rejected with a message: what a bad file should get
  }
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
