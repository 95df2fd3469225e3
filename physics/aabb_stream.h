// Recorded AABB streams in Broadmark's `.aabbs` layout (docs/SCENES.md, "The
// .aabbs layout"), little-endian:
//   char[128] scene name, char[128] object type (NUL-padded, printable),
//   int32 N > 0, int32 F > 0, int32 0, int32 0, world AABB,
//   then F + 1 frames of N AABBs; an AABB is min then max, each float32 x, y, z, 0.
// The reader checks everything before handing out a single box: sizes that
// match the counts, finite coordinates, min <= max; the first problem is
// reported with the file, frame and object.  The writer refuses the same
// boxes, so every file it writes reads back.  The fourth float of each
// corner is written as 0 and not checked on reading.
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

// The box stored for `object` of `objects` once it has left the simulation.
Aabb parkedBox(const Aabb& world, int object, int objects);

// Throws AabbStreamError naming the file and the first problem.
AabbStream readAabbStream(const std::filesystem::path& path);

// Writes through physics/atomic_file.h; throws AabbStreamError for an
// inconsistent stream or a box the reader would refuse (naming its frame and
// object), std::runtime_error when the file cannot be written.
void writeAabbStream(const std::filesystem::path& path, const AabbStream& stream);

}  // namespace overlap::physics
