// WavWriter: streams interleaved stereo float samples to a 16-bit PCM RIFF/WAVE
// file, so a run's sound can be listened to and compared byte for byte.
//
// The header is written first with zero sizes and patched by close(), which is
// the only point where the file is a valid WAV.  Samples are clamped to
// [-1, 1] and rounded to the nearest int16; everything is written
// little-endian byte by byte, so the same samples give the same bytes on every
// machine.  Every error is a std::runtime_error naming the file.
#pragma once

#include <cstdint>
#include <fstream>
#include <span>
#include <string>
#include <vector>

namespace overlap::stubs {

class WavWriter {
 public:
  static constexpr int kChannels = 2;
  static constexpr int kBitsPerSample = 16;
  static constexpr std::uint32_t kHeaderBytes = 44;

  // Creates (truncates) `path`; throws if it cannot be opened for writing.
  explicit WavWriter(std::string path, int sample_rate = 48000);
  // Closes the file if close() was not called; errors there are swallowed, so
  // call close() to see them.
  ~WavWriter();
  WavWriter(const WavWriter&) = delete;
  WavWriter& operator=(const WavWriter&) = delete;

  // Appends interleaved left/right samples; the size must be even.
  void appendStereo(std::span<const float> interleaved);
  // Writes the RIFF and data sizes into the header and closes the file.
  void close();

  const std::string& path() const { return path_; }
  int sampleRate() const { return sample_rate_; }
  // Stereo sample frames (left/right pairs) written so far.
  std::uint64_t sampleFrames() const { return data_bytes_ / (kChannels * kBitsPerSample / 8); }

 private:
  void fail(const std::string& what) const;

  std::string path_;
  int sample_rate_;
  std::ofstream file_;
  std::uint64_t data_bytes_ = 0;
  std::vector<unsigned char> encoded_;  // reused between appends
};

}  // namespace overlap::stubs
