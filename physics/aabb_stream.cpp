#include "physics/aabb_stream.h"

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <system_error>

#include "physics/atomic_file.h"

namespace overlap::physics {
namespace {

static_assert(std::endian::native == std::endian::little,
              "the .aabbs layout is little-endian; add byte swapping for this machine");

constexpr std::size_t kNameBytes = 128;
// How far beyond the world's +x face parkedBox() puts its points: inside the
// margin BroadphaseReplay gives SAP's quantized bounds (12.5% + 1 m).
constexpr float kParkingDistance = 0.5f;
constexpr std::size_t kAabbBytes = 8 * sizeof(float);
constexpr std::size_t kHeaderBytes = 2 * kNameBytes + 4 * sizeof(std::int32_t) + kAabbBytes;

[[noreturn]] void fail(const std::filesystem::path& path, const std::string& problem) {
  throw AabbStreamError(path.string() + ": " + problem);
}

std::string readName(const char* field, const std::filesystem::path& path, const char* what) {
  const std::size_t length = strnlen(field, kNameBytes);
  for (std::size_t i = 0; i < kNameBytes; ++i) {
    const auto c = static_cast<unsigned char>(field[i]);
    if (i < length && (c < 0x20 || c > 0x7e)) fail(path, std::string(what) + " is not printable");
    if (i >= length && c != 0) fail(path, std::string(what) + " is not NUL-padded");
  }
  return std::string(field, length);
}

Aabb decodeAabb(const char* bytes) {
  float corners[8];
  std::memcpy(corners, bytes, sizeof(corners));
  return Aabb{{corners[0], corners[1], corners[2]}, {corners[4], corners[5], corners[6]}};
}

void encodeAabb(const Aabb& box, char* bytes) {
  const float corners[8] = {box.min[0], box.min[1], box.min[2], 0.0f,
                            box.max[0], box.max[1], box.max[2], 0.0f};
  std::memcpy(bytes, corners, sizeof(corners));
}

// Empty when the box is well-formed, else what is wrong with it.
std::string aabbProblem(const Aabb& box) {
  static constexpr char kAxes[] = "xyz";
  for (int axis = 0; axis < 3; ++axis) {
    if (!std::isfinite(box.min[axis]) || !std::isfinite(box.max[axis])) {
      return std::string("non-finite ") + kAxes[axis];
    }
    if (box.min[axis] > box.max[axis]) return std::string("min > max on ") + kAxes[axis];
  }
  return {};
}

}  // namespace

Aabb parkedBox(const Aabb& world, int object, int objects) {
  const auto columns = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(objects))));
  const int row = object / columns;
  const int column = object % columns;
  auto along = [&](int axis, int cell) {
    const float span = world.max[axis] - world.min[axis];
    return world.min[axis] + span * (static_cast<float>(cell) + 0.5f) / static_cast<float>(columns);
  };
  const float x = world.max[0] + kParkingDistance;
  const float y = along(1, row);
  const float z = along(2, column);
  return Aabb{{x, y, z}, {x, y, z}};
}

AabbStream readAabbStream(const std::filesystem::path& path) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) fail(path, "is a directory, not a .aabbs file");
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open");
  std::vector<char> bytes;
  try {
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  } catch (const std::ios_base::failure& failure) {  // libstdc++ throws on EISDIR and the like
    fail(path, std::string("cannot read: ") + failure.what());
  }
  if (in.bad()) fail(path, "cannot read");
  if (bytes.size() < kHeaderBytes) {
    fail(path, "truncated header: " + std::to_string(bytes.size()) + " bytes, need " +
                   std::to_string(kHeaderBytes));
  }
  AabbStream stream;
  stream.scene_name = readName(bytes.data(), path, "scene name");
  stream.object_type = readName(bytes.data() + kNameBytes, path, "object type");
  std::int32_t counts[4];
  std::memcpy(counts, bytes.data() + 2 * kNameBytes, sizeof(counts));
  if (counts[0] <= 0) fail(path, "object count " + std::to_string(counts[0]) + " is not positive");
  if (counts[1] <= 0) fail(path, "frame count " + std::to_string(counts[1]) + " is not positive");
  // F + 1 frames are stored, and that count must fit the same int32.
  if (counts[1] == std::numeric_limits<std::int32_t>::max()) {
    fail(path, "frame count " + std::to_string(counts[1]) + " is too large");
  }
  if (counts[2] != 0 || counts[3] != 0) fail(path, "reserved header fields are not 0");
  stream.objects = counts[0];
  stream.stored_frames = counts[1] + 1;
  stream.world = decodeAabb(bytes.data() + 2 * kNameBytes + sizeof(counts));
  if (const std::string problem = aabbProblem(stream.world); !problem.empty()) {
    fail(path, "world AABB: " + problem);
  }

  // Compared as box counts: N x (F + 1) x 32 bytes could overflow 64 bits.
  const auto boxes = static_cast<std::uint64_t>(stream.objects) * stream.stored_frames;
  const std::uint64_t payload = bytes.size() - kHeaderBytes;
  if (payload % kAabbBytes != 0 || payload / kAabbBytes != boxes) {
    const std::uint64_t complete_frames =
        payload / (kAabbBytes * static_cast<std::uint64_t>(stream.objects));
    fail(path, "size " + std::to_string(bytes.size()) + " bytes does not match " +
                   std::to_string(stream.objects) + " objects x " +
                   std::to_string(stream.stored_frames) + " frames (" + std::to_string(boxes) +
                   " boxes of 32 bytes after the header); first incomplete frame " +
                   std::to_string(complete_frames));
  }
  stream.boxes.resize(boxes);
  for (std::uint64_t i = 0; i < boxes; ++i) {
    stream.boxes[i] = decodeAabb(bytes.data() + kHeaderBytes + i * kAabbBytes);
    if (const std::string problem = aabbProblem(stream.boxes[i]); !problem.empty()) {
      fail(path, "frame " + std::to_string(i / stream.objects) + ", object " +
                     std::to_string(i % stream.objects) + ": " + problem);
    }
  }
  return stream;
}

void writeAabbStream(const std::filesystem::path& path, const AabbStream& stream) {
  if (stream.objects <= 0 || stream.stored_frames < 2 ||
      stream.boxes.size() != static_cast<std::size_t>(stream.objects) * stream.stored_frames) {
    throw AabbStreamError(path.string() + ": inconsistent stream to write");
  }
  // Every box readAabbStream() would refuse is refused here, before a byte is written.
  if (const std::string problem = aabbProblem(stream.world); !problem.empty()) {
    fail(path, "world AABB to write: " + problem);
  }
  for (std::size_t i = 0; i < stream.boxes.size(); ++i) {
    if (const std::string problem = aabbProblem(stream.boxes[i]); !problem.empty()) {
      fail(path, "box to write at frame " + std::to_string(i / stream.objects) + ", object " +
                     std::to_string(i % stream.objects) + ": " + problem);
    }
  }
  std::vector<char> bytes(kHeaderBytes + stream.boxes.size() * kAabbBytes, 0);
  std::memcpy(bytes.data(), stream.scene_name.data(),
              std::min(stream.scene_name.size(), kNameBytes - 1));
  std::memcpy(bytes.data() + kNameBytes, stream.object_type.data(),
              std::min(stream.object_type.size(), kNameBytes - 1));
  const std::int32_t counts[4] = {stream.objects, stream.stored_frames - 1, 0, 0};
  std::memcpy(bytes.data() + 2 * kNameBytes, counts, sizeof(counts));
  encodeAabb(stream.world, bytes.data() + 2 * kNameBytes + sizeof(counts));
  for (std::size_t i = 0; i < stream.boxes.size(); ++i) {
    encodeAabb(stream.boxes[i], bytes.data() + kHeaderBytes + i * kAabbBytes);
  }

  writeFileAtomically(path, std::string_view(bytes.data(), bytes.size()));
}

}  // namespace overlap::physics
