#include "audio_ai_stubs/wav_writer.h"

#include <algorithm>
#include <cmath>
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

// The data size a header written before the end says: the largest.
constexpr std::uint32_t kStreamingDataBytes = 0xFFFFFFFFu - (WavWriter::kHeaderBytes - 8);

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

WavWriter::WavWriter(OutputFile& file, int sample_rate) : file_(file), sample_rate_(sample_rate) {
  if (sample_rate_ <= 0) fail("sample rate " + std::to_string(sample_rate_) + " must be positive");
  // "Until it ends" (the largest sizes) until close() patches them: what a
  // stop leaves of a file written as it went, and a stream that cannot be
  // patched, stay readable.
  const std::vector<unsigned char> placeholder = header(sample_rate_, kStreamingDataBytes);
  file_.write(
      std::string_view(reinterpret_cast<const char*>(placeholder.data()), placeholder.size()));
}

void WavWriter::appendStereo(std::span<const float> interleaved) {
  if (closed_) fail("append after close");
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
  file_.write(std::string_view(reinterpret_cast<const char*>(encoded_.data()), encoded_.size()));
  data_bytes_ += added;
}

void WavWriter::close() {
  if (closed_) return;
  closed_ = true;
  if (file_.rewritable()) {
    const std::vector<unsigned char> final_header =
        header(sample_rate_, static_cast<std::uint32_t>(data_bytes_));
    file_.rewrite(0, std::string_view(reinterpret_cast<const char*>(final_header.data()),
                                      final_header.size()));
  }
  file_.finish();
}

void WavWriter::fail(const std::string& what) const {
  throw std::runtime_error("WavWriter: '" + file_.path().string() + "': " + what);
}

}  // namespace overlap::stubs
