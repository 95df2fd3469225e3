#include "audio_ai_stubs/wav_writer.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string_view>

namespace overlap::stubs {
namespace {

void putLittleEndian(std::vector<unsigned char>& out, std::uint32_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<unsigned char>(value >> (8 * i)));
}

void putTag(std::vector<unsigned char>& out, std::string_view tag) {
  for (const char c : tag) out.push_back(static_cast<unsigned char>(c));
}

std::vector<unsigned char> header(int sample_rate, std::uint32_t data_bytes) {
  constexpr std::uint32_t kBlockAlign = WavWriter::kChannels * WavWriter::kBitsPerSample / 8;
  std::vector<unsigned char> out;
  out.reserve(WavWriter::kHeaderBytes);
  putTag(out, "RIFF");
  putLittleEndian(out, WavWriter::kHeaderBytes - 8 + data_bytes, 4);
  putTag(out, "WAVE");
  putTag(out, "fmt ");
  putLittleEndian(out, 16, 4);  // size of the PCM fmt chunk
  putLittleEndian(out, 1, 2);   // format 1: integer PCM
  putLittleEndian(out, WavWriter::kChannels, 2);
  putLittleEndian(out, static_cast<std::uint32_t>(sample_rate), 4);
  putLittleEndian(out, static_cast<std::uint32_t>(sample_rate) * kBlockAlign, 4);  // byte rate
  putLittleEndian(out, kBlockAlign, 2);
  putLittleEndian(out, WavWriter::kBitsPerSample, 2);
  putTag(out, "data");
  putLittleEndian(out, data_bytes, 4);
  return out;
}

}  // namespace

WavWriter::WavWriter(std::string path, int sample_rate)
    : path_(std::move(path)), sample_rate_(sample_rate) {
  if (sample_rate_ <= 0) {
    throw std::runtime_error("WavWriter: sample rate " + std::to_string(sample_rate_) + " for '" +
                             path_ + "' must be positive");
  }
  errno = 0;
  file_.open(path_, std::ios::binary | std::ios::trunc);
  if (!file_) {
    fail(errno != 0 ? "cannot open for writing: " + std::string(std::strerror(errno))
                    : "cannot open for writing");
  }
  const std::vector<unsigned char> placeholder = header(sample_rate_, 0);
  file_.write(reinterpret_cast<const char*>(placeholder.data()),
              static_cast<std::streamsize>(placeholder.size()));
  if (!file_) fail("cannot write the header");
}

WavWriter::~WavWriter() {
  try {
    close();
  } catch (const std::exception&) {
    // A destructor must not throw; callers who care call close() themselves.
  }
}

void WavWriter::appendStereo(std::span<const float> interleaved) {
  if (!file_.is_open()) fail("append after close");
  if (interleaved.size() % kChannels != 0) {
    fail("append of " + std::to_string(interleaved.size()) +
         " samples, not a whole number of stereo frames");
  }
  // The RIFF sizes are 32-bit: refuse to write a file whose header would lie.
  const std::uint64_t added = interleaved.size() * (kBitsPerSample / 8);
  if (kHeaderBytes - 8 + data_bytes_ + added > std::numeric_limits<std::uint32_t>::max()) {
    fail("data would exceed the 4 GiB a RIFF header can describe");
  }
  encoded_.clear();
  for (const float sample : interleaved) {
    const float clamped = std::clamp(sample, -1.0f, 1.0f);
    const auto pcm = static_cast<std::int16_t>(std::lround(clamped * 32767.0f));
    putLittleEndian(encoded_, static_cast<std::uint16_t>(pcm), 2);
  }
  file_.write(reinterpret_cast<const char*>(encoded_.data()),
              static_cast<std::streamsize>(encoded_.size()));
  if (!file_) fail("cannot write samples");
  data_bytes_ += added;
}

void WavWriter::close() {
  if (!file_.is_open()) return;
  const std::vector<unsigned char> final_header =
      header(sample_rate_, static_cast<std::uint32_t>(data_bytes_));
  file_.seekp(0);
  file_.write(reinterpret_cast<const char*>(final_header.data()),
              static_cast<std::streamsize>(final_header.size()));
  file_.close();
  if (!file_) fail("cannot finish the header");
}

void WavWriter::fail(const std::string& what) const {
  throw std::runtime_error("WavWriter: '" + path_ + "': " + what);
}

}  // namespace overlap::stubs
