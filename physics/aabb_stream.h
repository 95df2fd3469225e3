// Recorded AABB streams in Broadmark's `.aabbs` layout (docs/SCENES.md, "The
// .aabbs layout"), little-endian:
//   char[128] scene name, char[128] object type (NUL-padded, printable),
//   int32 N > 0, int32 F > 0, int32 0, int32 0, world AABB,
//   then F + 1 frames of N AABBs; an AABB is min then max, each float32 x, y, z, 0.
// The reader checks the header before it reads a box: names NUL-padded
// within their 128 bytes, positive counts and, for a file with a size, that
// size against the counts, so no count in a header makes it allocate more
// than the file holds.  A stream without a size (a pipe, /dev/zero) is read
// one frame at a time, memory bounded by one frame (and by the bytes that
// arrived).  Every box must be finite with min <= max and a fourth float of
// 0; the first problem is reported with the file, frame and object.  The
// writer refuses the same boxes, so every file it writes reads back.
//
// A box that has left the simulation (Bullet took it out: NaN, a huge AABB,
// too far away) still needs N boxes in each frame.  It is stored "parked":
// a point (min = max) half a metre beyond the world AABB's +x face, at its
// own cell of a ceil(sqrt(N))-square grid over that face.  Parked boxes are
// valid AABBs, outside the world, touching nothing inside it and no other
// parked box, so an exact broadphase pairs them with nothing, as the
// simulation's pair cache does.
#pragma once

#include <filesystem>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "physics/aabb.h"

namespace overlap::physics {

struct AabbStreamError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A stream's header: everything but the boxes.
struct AabbStreamHeader {
  std::string scene_name;
  std::string object_type;
  int objects = 0;        // N
  int stored_frames = 0;  // F + 1
  Aabb world{};
};

// A whole stream in memory.
struct AabbStream : AabbStreamHeader {
  std::vector<Aabb> boxes;  // stored_frames * objects, frame-major

  std::span<const Aabb> frame(int f) const {
    return std::span<const Aabb>(boxes).subspan(static_cast<std::size_t>(f) * objects,
                                                static_cast<std::size_t>(objects));
  }
};

// The box stored for `object` of `objects` once it has left the simulation.
Aabb parkedBox(const Aabb& world, int object, int objects);

// Reads a stream a frame at a time.  Every error is an AabbStreamError
// naming the file and the first problem (with its frame and object).
class AabbStreamReader {
 public:
  // Opens `path` and reads and checks the header (and the size, if it has one).
  explicit AabbStreamReader(const std::filesystem::path& path);
  ~AabbStreamReader();
  AabbStreamReader(const AabbStreamReader&) = delete;
  AabbStreamReader& operator=(const AabbStreamReader&) = delete;

  const AabbStreamHeader& header() const { return header_; }
  // True for a regular file: its size was checked against the header.
  bool sized() const { return sized_; }
  // Reads the next stored frame into `boxes`, checked; false after the last
  // (a stream without a size must end there).
  bool next(std::vector<Aabb>& boxes);
  // For a file with a size: reads and checks every frame, then starts again
  // at the first, so a bad box is found before anything is done with the
  // good ones.
  void checkAll();

 private:
  void checkHeader();  // reads and checks the header, sized files against their size
  std::size_t readUpTo(char* bytes, std::size_t count);  // short only at the end
  [[noreturn]] void fail(const std::string& problem) const;

  std::filesystem::path path_;
  int fd_ = -1;
  bool sized_ = false;
  AabbStreamHeader header_;
  int frames_read_ = 0;
  std::vector<char> chunk_;  // raw bytes of part of a frame
};

// The whole stream in memory, through AabbStreamReader.
AabbStream readAabbStream(const std::filesystem::path& path);

// Writes through gpu/base/output_file.h; throws AabbStreamError for an
// inconsistent stream or a box the reader would refuse (naming its frame and
// object), std::runtime_error when the file cannot be written.
void writeAabbStream(const std::filesystem::path& path, const AabbStream& stream);

}  // namespace overlap::physics
