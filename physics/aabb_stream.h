// Recorded AABB streams in Broadmark's `.aabbs` layout (SCENES.md,
// "Interchange"), little-endian:
//   char[128] scene name, char[128] object type (NUL-padded, printable),
//   int32 N > 0, int32 F > 0, int32 0, int32 0, world AABB,
//   then F + 1 frames of N AABBs; an AABB is min then max, each float32 x, y, z, 0.
// The reader checks everything before handing out a single box: sizes that
// match the counts, finite coordinates, min <= max; the first problem is
// reported with the file, frame and object.  The fourth float of each corner
// is written as 0 and not checked on reading.
#pragma once

#include <filesystem>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "physics/world.h"

namespace overlap::physics {

struct AabbStreamError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct AabbStream {
  std::string scene_name;
  std::string object_type;
  int objects = 0;        // N
  int stored_frames = 0;  // F + 1
  Aabb world{};
  std::vector<Aabb> boxes;  // stored_frames * objects, frame-major

  std::span<const Aabb> frame(int f) const {
    return std::span<const Aabb>(boxes).subspan(static_cast<std::size_t>(f) * objects,
                                                static_cast<std::size_t>(objects));
  }
};

// Throws AabbStreamError naming the file and the first problem.
AabbStream readAabbStream(const std::filesystem::path& path);

// Writes through physics/atomic_file.h; throws AabbStreamError for an
// inconsistent stream and std::runtime_error when the file cannot be written.
void writeAabbStream(const std::filesystem::path& path, const AabbStream& stream);

}  // namespace overlap::physics
