#include "physics/aabb_stream.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>

#include "gpu/base/interrupt.h"
#include "gpu/base/output_file.h"

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
  // An empty name is shown as one, not as nothing before the colon.
  throw AabbStreamError((path.empty() ? std::string("\"\" (an empty name)") : path.string()) +
                        ": " + problem);
}

std::string readName(const char* field, const std::filesystem::path& path, const char* what) {
  const std::size_t length = strnlen(field, kNameBytes);
  if (length == kNameBytes) fail(path, std::string(what) + " has no NUL within its 128 bytes");
  for (std::size_t i = 0; i < kNameBytes; ++i) {
    const auto c = static_cast<unsigned char>(field[i]);
    if (i < length && (c < 0x20 || c > 0x7e)) fail(path, std::string(what) + " is not printable");
    if (i >= length && c != 0) fail(path, std::string(what) + " is not NUL-padded");
  }
  return std::string(field, length);
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

// Decodes a stored AABB into `box`; empty when it is well-formed (its
// fourth floats 0 as the layout requires), else what is wrong with it.
std::string decodeAabb(const char* bytes, Aabb& box) {
  float corners[8];
  std::memcpy(corners, bytes, sizeof(corners));
  box = Aabb{{corners[0], corners[1], corners[2]}, {corners[4], corners[5], corners[6]}};
  for (const int w : {3, 7}) {
    if (!(corners[w] == 0.0f)) {
      char shown[32];
      std::snprintf(shown, sizeof(shown), "%g", static_cast<double>(corners[w]));
      return std::string("the fourth float of ") + (w == 3 ? "min" : "max") + " is " + shown +
             ", not 0";
    }
  }
  return aabbProblem(box);
}

void encodeAabb(const Aabb& box, char* bytes) {
  const float corners[8] = {box.min[0], box.min[1], box.min[2], 0.0f,
                            box.max[0], box.max[1], box.max[2], 0.0f};
  std::memcpy(bytes, corners, sizeof(corners));
}

}  // namespace

std::uint64_t aabbStreamBytes(const AabbStreamHeader& header) {
  return kHeaderBytes + static_cast<std::uint64_t>(header.objects) *
                            static_cast<std::uint64_t>(header.stored_frames) * kAabbBytes;
}

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

AabbStreamReader::AabbStreamReader(const std::filesystem::path& path) : path_(path) {
  // Not blocking in open(): a FIFO without a writer is waited for in
  // awaitData(), where a signal stops the wait.
  fd_ = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) fail(std::string("cannot open: ") + std::strerror(errno));
  ::fcntl(fd_, F_SETFL, ::fcntl(fd_, F_GETFL) & ~O_NONBLOCK);
  // A refused header throws from here, where no destructor will close the file.
  try {
    checkHeader();
  } catch (...) {
    ::close(fd_);
    throw;
  }
}

void AabbStreamReader::checkHeader() {
  struct stat info {};
  if (::fstat(fd_, &info) != 0) fail(std::string("cannot read: ") + std::strerror(errno));
  if (S_ISDIR(info.st_mode)) fail("is a directory, not a .aabbs file");
  sized_ = S_ISREG(info.st_mode);

  char bytes[kHeaderBytes];
  const std::size_t got = readUpTo(bytes, kHeaderBytes);
  if (got < kHeaderBytes) {
    fail("truncated header: " + std::to_string(got) + " bytes, need " +
         std::to_string(kHeaderBytes));
  }
  header_.scene_name = readName(bytes, path_, "scene name");
  header_.object_type = readName(bytes + kNameBytes, path_, "object type");
  std::int32_t counts[4];
  std::memcpy(counts, bytes + 2 * kNameBytes, sizeof(counts));
  if (counts[0] <= 0) fail("object count " + std::to_string(counts[0]) + " is not positive");
  if (counts[1] <= 0) fail("frame count " + std::to_string(counts[1]) + " is not positive");
  // F + 1 frames are stored, and that count must fit the same int32.
  if (counts[1] == std::numeric_limits<std::int32_t>::max()) {
    fail("frame count " + std::to_string(counts[1]) + " is too large");
  }
  if (counts[2] != 0 || counts[3] != 0) fail("reserved header fields are not 0");
  header_.objects = counts[0];
  header_.stored_frames = counts[1] + 1;
  if (const std::string problem =
          decodeAabb(bytes + 2 * kNameBytes + sizeof(counts), header_.world);
      !problem.empty()) {
    fail("world AABB: " + problem);
  }
  if (!sized_) return;

  // Compared as box counts: N x (F + 1) x 32 bytes could overflow 64 bits.
  const auto file_bytes = static_cast<std::uint64_t>(info.st_size);
  const auto boxes = static_cast<std::uint64_t>(header_.objects) * header_.stored_frames;
  const std::uint64_t payload = file_bytes - kHeaderBytes;
  if (payload % kAabbBytes != 0 || payload / kAabbBytes != boxes) {
    // Every frame there and bytes beyond them, or the first frame cut short.
    const std::uint64_t extra = payload / kAabbBytes >= boxes ? payload - boxes * kAabbBytes : 0;
    const std::string where =
        extra > 0
            ? std::to_string(extra) + (extra == 1 ? " byte" : " bytes") + " after the last frame"
            : "first incomplete frame " +
                  std::to_string(payload /
                                 (kAabbBytes * static_cast<std::uint64_t>(header_.objects)));
    fail("size " + std::to_string(file_bytes) + " bytes does not match " +
         std::to_string(header_.objects) + " objects x " + std::to_string(header_.stored_frames) +
         " frames (" + std::to_string(boxes) + " boxes of 32 bytes after the header); " + where);
  }
}

AabbStreamReader::~AabbStreamReader() {
  if (fd_ >= 0) ::close(fd_);
}

void AabbStreamReader::fail(const std::string& problem) const {
  ::overlap::physics::fail(path_, problem);
}

std::string AabbStreamReader::position() const {
  if (header_.stored_frames == 0) return "the header of " + path_.string();
  return "frame " + std::to_string(frames_read_) + " of " + std::to_string(header_.stored_frames) +
         " of " + path_.string();
}

void AabbStreamReader::awaitData() const {
  waitUntil(
      [this](int timeout_ms) {
        pollfd watched{fd_, POLLIN, 0};
        const int ready = ::poll(&watched, 1, timeout_ms);
        // Data, the writer gone, or an error that read() will report.
        return ready > 0 || (ready < 0 && errno != EINTR);
      },
      "waiting for data on " + path_.string() + " (its writer has sent nothing for a second)",
      position() + ", waiting for data");
}

std::size_t AabbStreamReader::readUpTo(char* bytes, std::size_t count) {
  std::size_t got = 0;
  while (got < count) {
    if (!sized_) awaitData();
    const ssize_t read = ::read(fd_, bytes + got, count - got);
    if (read < 0 && errno == EINTR) {
      stopIfInterrupted(position());
      continue;
    }
    if (read < 0) fail(std::string("cannot read: ") + std::strerror(errno));
    if (read == 0) break;
    got += static_cast<std::size_t>(read);
  }
  return got;
}

bool AabbStreamReader::next(std::vector<Aabb>& boxes) {
  if (frames_read_ == header_.stored_frames) {
    char extra = 0;
    if (!sized_ && readUpTo(&extra, 1) > 0) {
      fail("more bytes after the last of " + std::to_string(header_.stored_frames) + " frames");
    }
    return false;
  }
  // Read in chunks, so a header's count alone never allocates: a stream
  // without a size grows `boxes` only as its bytes arrive.
  constexpr std::size_t kChunkBoxes = 1 << 14;
  const auto objects = static_cast<std::size_t>(header_.objects);
  boxes.clear();
  while (boxes.size() < objects) {
    const std::size_t count = std::min(kChunkBoxes, objects - boxes.size());
    chunk_.resize(count * kAabbBytes);
    const std::size_t got = readUpTo(chunk_.data(), chunk_.size());
    if (got < chunk_.size()) {
      fail("frame " + std::to_string(frames_read_) + ": the stream ends after object " +
           std::to_string(boxes.size() + got / kAabbBytes) + " of " + std::to_string(objects) +
           " (" + std::to_string(header_.stored_frames) + " frames of " + std::to_string(objects) +
           " boxes expected)");
    }
    for (std::size_t i = 0; i < count; ++i) {
      Aabb box;
      if (const std::string problem = decodeAabb(chunk_.data() + i * kAabbBytes, box);
          !problem.empty()) {
        fail("frame " + std::to_string(frames_read_) + ", object " + std::to_string(boxes.size()) +
             ": " + problem);
      }
      boxes.push_back(box);
    }
  }
  ++frames_read_;
  return true;
}

void AabbStreamReader::checkAll() {
  if (!sized_) fail("cannot be read twice: it has no size (a pipe or a device)");
  std::vector<Aabb> boxes;
  while (next(boxes)) {
  }
  if (::lseek(fd_, static_cast<off_t>(kHeaderBytes), SEEK_SET) < 0) {
    fail(std::string("cannot read: ") + std::strerror(errno));
  }
  frames_read_ = 0;
}

AabbStream readAabbStream(const std::filesystem::path& path) {
  AabbStreamReader reader(path);
  return readAabbStream(reader);
}

AabbStream readAabbStream(AabbStreamReader& reader) {
  AabbStream stream;
  const AabbStreamHeader& header = reader.header();
  static_cast<AabbStreamHeader&>(stream) = header;
  // The size matched the counts: the file holds every box reserved here.
  if (reader.sized())
    stream.boxes.reserve(static_cast<std::size_t>(header.objects) * header.stored_frames);
  std::vector<Aabb> frame;
  while (reader.next(frame)) stream.boxes.insert(stream.boxes.end(), frame.begin(), frame.end());
  return stream;
}

namespace {

std::string boxProblemAt(const Aabb& box, std::size_t frame, std::size_t object) {
  const std::string problem = aabbProblem(box);
  if (problem.empty()) return problem;
  return "box to write at frame " + std::to_string(frame) + ", object " + std::to_string(object) +
         ": " + problem;
}

}  // namespace

AabbStreamWriter::AabbStreamWriter(const std::filesystem::path& path,
                                   const AabbStreamHeader& header, FinalLink link)
    : header_(header) {
  if (header.objects <= 0 || header.stored_frames < 2) {
    fail(path, "inconsistent stream to write");
  }
  if (const std::string problem = aabbProblem(header.world); !problem.empty()) {
    fail(path, "world AABB to write: " + problem);
  }
  std::vector<char> bytes(kHeaderBytes, 0);
  std::memcpy(bytes.data(), header.scene_name.data(),
              std::min(header.scene_name.size(), kNameBytes - 1));
  std::memcpy(bytes.data() + kNameBytes, header.object_type.data(),
              std::min(header.object_type.size(), kNameBytes - 1));
  const std::int32_t counts[4] = {header.objects, header.stored_frames - 1, 0, 0};
  std::memcpy(bytes.data() + 2 * kNameBytes, counts, sizeof(counts));
  encodeAabb(header.world, bytes.data() + 2 * kNameBytes + sizeof(counts));
  file_ = std::make_unique<OutputFile>(path, link);
  file_->write(std::string_view(bytes.data(), bytes.size()));
}

AabbStreamWriter::~AabbStreamWriter() = default;

void AabbStreamWriter::write(std::span<const Aabb> boxes) {
  const std::filesystem::path& path = file_->path();
  if (boxes.size() != static_cast<std::size_t>(header_.objects) ||
      frames_written_ == header_.stored_frames) {
    fail(path, "inconsistent stream to write");
  }
  bytes_.resize(boxes.size() * kAabbBytes);
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    if (const std::string problem = boxProblemAt(boxes[i], frames_written_, i); !problem.empty()) {
      fail(path, problem);
    }
    encodeAabb(boxes[i], bytes_.data() + i * kAabbBytes);
  }
  file_->write(std::string_view(bytes_.data(), bytes_.size()));
  ++frames_written_;
}

void AabbStreamWriter::commit() {
  if (frames_written_ != header_.stored_frames) {
    fail(file_->path(), "inconsistent stream to write: " + std::to_string(frames_written_) +
                            " of " + std::to_string(header_.stored_frames) + " frames written");
  }
  file_->commit();
}

void writeAabbStream(const std::filesystem::path& path, const AabbStream& stream, FinalLink link) {
  if (stream.objects <= 0 || stream.stored_frames < 2 ||
      stream.boxes.size() != static_cast<std::size_t>(stream.objects) * stream.stored_frames) {
    throw AabbStreamError(path.string() + ": inconsistent stream to write");
  }
  // Every box readAabbStream() would refuse is refused here, before a byte
  // is written (a FIFO keeps what it was sent).
  for (std::size_t i = 0; i < stream.boxes.size(); ++i) {
    const std::size_t objects = static_cast<std::size_t>(stream.objects);
    if (const std::string problem = boxProblemAt(stream.boxes[i], i / objects, i % objects);
        !problem.empty()) {
      fail(path, problem);
    }
  }
  AabbStreamWriter writer(path, stream, link);
  for (int frame = 0; frame < stream.stored_frames; ++frame) writer.write(stream.frame(frame));
  writer.commit();
}

}  // namespace overlap::physics
