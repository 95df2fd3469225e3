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

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "gpu/base/output_file.h"
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

// The bytes of a stream with `header`'s counts, header included.
std::uint64_t aabbStreamBytes(const AabbStreamHeader& header);

// The box stored for `object` of `objects` once it has left the simulation.
Aabb parkedBox(const Aabb& world, int object, int objects);

// Reads a stream a frame at a time.  Every error is an AabbStreamError
// naming the file and the first problem (with its frame and object).  A
// stream without a size is waited for through gpu/base/interrupt.h's
// waitUntil(): a FIFO without a writer or a stalled writer is said on stderr
// after a second, and a signal stops the wait (Interrupted).
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
  void awaitData() const;                                // until a read will not block
  std::string position() const;                          // "frame 3 of 31 of FILE"
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
// The frames `reader` has not yet read, with its header: a stream without a
// size (a pipe) can be read only once, so whoever opened it to check its
// header reads it through the same reader.
AabbStream readAabbStream(AabbStreamReader& reader);

// Writes a stream a frame at a time through gpu/base/output_file.h, so a
// writer holds one frame, not the whole stream: the header at construction,
// then write() each of its stored frames, then commit() publishes the file.
// Destroyed before commit(), it leaves the old file as it was (its
// temporary is removed).  Throws AabbStreamError for an inconsistent stream
// or a box the reader would refuse (naming its frame and object),
// OutputError when the file cannot be written.  `link` says how a symlink
// at `path` is taken (output_file.h): a name the user gave is followed; a
// name in a folder of the program's own (the benchmark's stream cache) is
// replaced, its target untouched.
class AabbStreamWriter {
 public:
  AabbStreamWriter(const std::filesystem::path& path, const AabbStreamHeader& header,
                   FinalLink link = FinalLink::kFollow);
  ~AabbStreamWriter();
  AabbStreamWriter(const AabbStreamWriter&) = delete;
  AabbStreamWriter& operator=(const AabbStreamWriter&) = delete;

  void write(std::span<const Aabb> boxes);  // the next stored frame, `header.objects` boxes
  void commit();                            // after the last frame

 private:
  AabbStreamHeader header_;
  std::unique_ptr<OutputFile> file_;
  int frames_written_ = 0;
  std::vector<char> bytes_;  // one frame, encoded
};

// The whole stream through AabbStreamWriter, every box checked before a
// byte is written.
void writeAabbStream(const std::filesystem::path& path, const AabbStream& stream,
                     FinalLink link = FinalLink::kFollow);

}  // namespace overlap::physics
