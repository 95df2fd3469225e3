// WavWriter: streams interleaved stereo float samples to a 16-bit PCM RIFF/WAVE
// file, so a run's sound can be listened to and compared byte for byte.
//
// It writes into a OutputFile the caller owns and publishes.  The header
// is written first with its sizes the largest (the RIFF size 0xFFFFFFFF,
// the data size 0xFFFFFFFF - 36): "until the stream ends",
// as streaming WAV writers do, and patched by close() where the output is
// rewritable(), which finishes the file (still under its temporary name
// until published).  So a FIFO or device, and a descriptor's file stopped
// part way or appended to by another holder, stay readable.  Samples are
// clamped to [-1, 1] and rounded to the nearest int16; everything is written
// little-endian byte by byte, so the same samples give the same bytes on every
// machine.  Every error is a std::runtime_error naming the file.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "gpu/base/output_file.h"

namespace overlap::stubs {

class WavWriter {
 public:
  static constexpr int kChannels = 2;
  static constexpr int kBitsPerSample = 16;
  static constexpr std::uint32_t kHeaderBytes = 44;

  // Writes the header into `file`; throws OutputError if it cannot.
  explicit WavWriter(OutputFile& file, int sample_rate = 48000);
  WavWriter(const WavWriter&) = delete;
  WavWriter& operator=(const WavWriter&) = delete;

  // Appends interleaved left/right samples; the size must be even.
  void appendStereo(std::span<const float> interleaved);
  // Writes the RIFF and data sizes into the header and finishes the file.
  void close();
  std::string path() const { return file_.path().string(); }
  int sampleRate() const { return sample_rate_; }
  // Stereo sample frames (left/right pairs) written so far.
  std::uint64_t sampleFrames() const { return data_bytes_ / (kChannels * kBitsPerSample / 8); }

 private:
  void fail(const std::string& what) const;

  OutputFile& file_;
  int sample_rate_;
  bool closed_ = false;
  std::uint64_t data_bytes_ = 0;
  std::vector<unsigned char> encoded_;  // reused between appends
};

}  // namespace overlap::stubs
