#include "audio_ai_stubs/wav_writer.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include "audio_ai_stubs/sound.h"
#include "tests/scratch_path.h"

namespace overlap::stubs {
namespace {

std::filesystem::path scratchFile(const std::string& tag) {
  const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
  return overlap::testing::scratchPath("stubs_" + std::string(test->name()) + "_" + tag + ".wav");
}

std::vector<unsigned char> readBytes(const std::filesystem::path& path) {
  std::ifstream file(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>()};
}

std::uint32_t readU32(const std::vector<unsigned char>& bytes, std::size_t at) {
  return bytes[at] | bytes[at + 1] << 8 | bytes[at + 2] << 16 |
         static_cast<std::uint32_t>(bytes[at + 3]) << 24;
}

std::uint16_t readU16(const std::vector<unsigned char>& bytes, std::size_t at) {
  return static_cast<std::uint16_t>(bytes[at] | bytes[at + 1] << 8);
}

std::string readTag(const std::vector<unsigned char>& bytes, std::size_t at) {
  return {bytes.begin() + static_cast<std::ptrdiff_t>(at),
          bytes.begin() + static_cast<std::ptrdiff_t>(at + 4)};
}

// Renders `frames` frames with an impact every third frame into a WAV file
// and returns the file's bytes.
std::vector<unsigned char> renderWav(const std::filesystem::path& path, std::uint64_t seed,
                                     float closing_speed, int frames = 6) {
  SoundConfig config;
  config.seed = seed;
  SoundMixer mixer(config);
  {
    OutputFile file(path);
    WavWriter writer(file);
    for (int frame = 0; frame < frames; ++frame) {
      const ImpactEvent impact{closing_speed, -0.3f, 1.0f};
      mixer.runFrame({&impact, frame % 3 == 0 ? 1u : 0u});
      mixer.appendMixTo(writer);
    }
    writer.close();
    file.publish();
  }
  std::vector<unsigned char> bytes = readBytes(path);
  std::filesystem::remove(path);
  return bytes;
}

TEST(WavWriter, HeaderFieldsDescribeTheSamples) {
  constexpr int kFrames = 3;
  const std::vector<unsigned char> bytes = renderWav(scratchFile("header"), 42, 4.0f, kFrames);
  constexpr std::uint32_t kDataBytes = kFrames * 1600 * 2 * 2;
  ASSERT_EQ(bytes.size(), WavWriter::kHeaderBytes + kDataBytes);
  EXPECT_EQ(readTag(bytes, 0), "RIFF");
  EXPECT_EQ(readU32(bytes, 4), bytes.size() - 8);
  EXPECT_EQ(readTag(bytes, 8), "WAVE");
  EXPECT_EQ(readTag(bytes, 12), "fmt ");
  EXPECT_EQ(readU32(bytes, 16), 16u);
  EXPECT_EQ(readU16(bytes, 20), 1u);  // PCM
  EXPECT_EQ(readU16(bytes, 22), 2u);  // stereo
  EXPECT_EQ(readU32(bytes, 24), 48000u);
  EXPECT_EQ(readU32(bytes, 28), 48000u * 4u);  // byte rate
  EXPECT_EQ(readU16(bytes, 32), 4u);           // block align
  EXPECT_EQ(readU16(bytes, 34), 16u);
  EXPECT_EQ(readTag(bytes, 36), "data");
  EXPECT_EQ(readU32(bytes, 40), kDataBytes);
}

TEST(WavWriter, CountsFramesAndClampsAndRoundsSamples) {
  const std::filesystem::path path = scratchFile("clamp");
  {
    OutputFile file(path);
    WavWriter writer(file);
    const std::vector<float> samples = {0.0f, 1.0f, -1.0f, 0.5f, 2.0f, -2.0f};
    writer.appendStereo(samples);
    EXPECT_EQ(writer.sampleFrames(), 3u);
    writer.close();
    file.publish();
  }
  const std::vector<unsigned char> bytes = readBytes(path);
  std::filesystem::remove(path);
  ASSERT_EQ(bytes.size(), WavWriter::kHeaderBytes + 12u);
  EXPECT_EQ(readU32(bytes, 40), 12u);
  const std::vector<std::int16_t> expected = {0, 32767, -32767, 16384, 32767, -32767};
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(static_cast<std::int16_t>(readU16(bytes, WavWriter::kHeaderBytes + 2 * i)),
              expected[i])
        << "sample " << i;
  }
}

TEST(WavWriter, SameSeedAndImpactsGiveIdenticalBytes) {
  EXPECT_EQ(renderWav(scratchFile("a"), 42, 4.0f), renderWav(scratchFile("b"), 42, 4.0f));
}

TEST(WavWriter, DifferentSeedOrImpactsGiveDifferentBytes) {
  const std::vector<unsigned char> reference = renderWav(scratchFile("a"), 42, 4.0f);
  EXPECT_NE(reference, renderWav(scratchFile("b"), 43, 4.0f));
  EXPECT_NE(reference, renderWav(scratchFile("c"), 42, 7.0f));
}

TEST(WavWriter, UnwritablePathThrowsNamingThePath) {
  const std::string path = "/dev/null/sound.wav";  // no folder can be made there, even by root
  try {
    OutputFile file(path);
    WavWriter writer(file);
    FAIL() << "opened " << path;
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find(path), std::string::npos) << error.what();
  }
}

TEST(WavWriter, OddSampleCountThrowsNamingThePath) {
  const std::filesystem::path path = scratchFile("odd");
  OutputFile file(path);
  WavWriter writer(file);
  const std::vector<float> three = {0.1f, 0.2f, 0.3f};
  try {
    writer.appendStereo(three);
    FAIL() << "accepted half a stereo frame";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find(path.string()), std::string::npos) << error.what();
  }
  writer.close();
}

// A FIFO cannot be patched: the header says "until the stream ends", the
// FIFO stays a FIFO and the samples go through it.
TEST(WavWriter, WritesThroughAFifoWithAStreamingHeader) {
  const std::filesystem::path fifo = scratchFile("fifo");
  std::filesystem::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::vector<unsigned char> received;
  std::thread reader([&] { received = readBytes(fifo); });
  {
    OutputFile file(fifo);
    ASSERT_TRUE(file.writtenThrough());
    WavWriter writer(file);
    writer.appendStereo(std::vector<float>{0.5f, -0.5f});
    writer.close();
    file.publish();
  }
  reader.join();
  EXPECT_TRUE(std::filesystem::is_fifo(fifo));
  std::filesystem::remove(fifo);
  ASSERT_EQ(received.size(), WavWriter::kHeaderBytes + 4u);
  EXPECT_EQ(readU32(received, 4), 0xFFFFFFFFu);
  EXPECT_EQ(readU16(received, WavWriter::kHeaderBytes), 16384u);
}

// A file reached through a descriptor is patched where the WAV began; until
// then, and where another holder of the descriptor has since made it
// append-only, its header says "until the stream ends": what was written
// as it went stays readable, and no header lands at the end.
TEST(WavWriter, ADescriptorsFileSaysUntilTheStreamEndsUntilPatched) {
  const std::filesystem::path path = scratchFile("descriptor");
  for (const bool appended_later : {false, true}) {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    ASSERT_GE(fd, 0);
    {
      OutputFile file("/dev/fd/" + std::to_string(fd));
      ASSERT_TRUE(file.rewritable());
      WavWriter writer(file);
      writer.appendStereo(std::vector<float>{0.5f, -0.5f});
      EXPECT_EQ(readU32(readBytes(path), 4), 0xFFFFFFFFu);  // stopped here: still readable
      if (appended_later) ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_APPEND);
      writer.close();
      file.publish();
    }
    ::close(fd);
    const std::vector<unsigned char> bytes = readBytes(path);
    ASSERT_EQ(bytes.size(), WavWriter::kHeaderBytes + 4u) << appended_later;
    EXPECT_EQ(readU32(bytes, 4), appended_later ? 0xFFFFFFFFu : WavWriter::kHeaderBytes - 8 + 4u);
  }
}

TEST(WavWriter, MixAtAnotherSampleRateIsRefused) {
  const std::filesystem::path path = scratchFile("rate");
  OutputFile file(path);
  WavWriter writer(file, 44100);
  SoundMixer mixer{SoundConfig{}};
  mixer.runFrame({});
  EXPECT_THROW(mixer.appendMixTo(writer), std::invalid_argument);
  writer.close();
}

}  // namespace
}  // namespace overlap::stubs
