// The .aabbs reader and writer, and replaying a stream through a broadphase.
#include "physics/aabb_stream.h"

#include <gtest/gtest.h>
#include <signal.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include "gpu/base/interrupt.h"
#include "physics/broadphase_replay.h"
#include "tests/scratch_path.h"

namespace overlap::physics {
namespace {

constexpr std::size_t kHeaderBytes = 304;

std::filesystem::path tempFile(const std::string& name) {
  return overlap::testing::scratchPath("stream_" + name + ".aabbs");
}

// Three boxes over two frames: 0 and 1 touch in frame 0, 1 and 2 overlap in frame 1.
AabbStream smallStream() {
  AabbStream stream;
  stream.scene_name = "test";
  stream.object_type = "box";
  stream.objects = 3;
  stream.stored_frames = 2;
  stream.world = Aabb{{-10, -10, -10}, {10, 10, 10}};
  stream.boxes = {
      Aabb{{0, 0, 0}, {1, 1, 1}}, Aabb{{1, 0, 0}, {2, 1, 1}}, Aabb{{5, 5, 5}, {6, 6, 6}},
      Aabb{{0, 0, 0}, {1, 1, 1}}, Aabb{{3, 0, 0}, {4, 1, 1}}, Aabb{{3.5f, 0.5f, 0}, {5, 2, 1}},
  };
  return stream;
}

void writeBytes(const std::filesystem::path& path, const std::vector<char>& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

std::string readError(const std::filesystem::path& path) {
  try {
    readAabbStream(path);
  } catch (const AabbStreamError& error) {
    return error.what();
  }
  return "no error";
}

TEST(AabbStream, RoundTripKeepsEveryField) {
  const auto path = tempFile("roundtrip");
  writeAabbStream(path, smallStream());
  EXPECT_EQ(std::filesystem::file_size(path), kHeaderBytes + 6 * 32);
  const AabbStream read = readAabbStream(path);
  EXPECT_EQ(read.scene_name, "test");
  EXPECT_EQ(read.object_type, "box");
  EXPECT_EQ(read.objects, 3);
  EXPECT_EQ(read.stored_frames, 2);
  ASSERT_EQ(read.boxes.size(), 6u);
  EXPECT_EQ(read.frame(1)[2].min[0], 3.5f);
  EXPECT_EQ(read.frame(1)[2].max[1], 2.0f);
  std::filesystem::remove(path);
}

TEST(AabbStream, MalformedFilesNameTheFileAndTheFirstBadBox) {
  const auto good = tempFile("good");
  writeAabbStream(good, smallStream());
  const std::vector<char> bytes = overlap::testing::fileBytes(good);
  const auto bad = tempFile("bad");

  writeBytes(bad, std::vector<char>(bytes.begin(), bytes.begin() + 100));
  EXPECT_NE(readError(bad).find("truncated header"), std::string::npos) << readError(bad);

  writeBytes(bad, std::vector<char>(bytes.begin(), bytes.end() - 40));
  EXPECT_NE(readError(bad).find("first incomplete frame 1"), std::string::npos) << readError(bad);

  std::vector<char> one_more = bytes;  // every frame whole, and a byte beyond them
  one_more.push_back(0);
  writeBytes(bad, one_more);
  EXPECT_NE(readError(bad).find("1 byte after the last frame"), std::string::npos)
      << readError(bad);

  std::vector<char> wrong_count = bytes;
  const std::int32_t five = 5;
  std::memcpy(wrong_count.data() + 256, &five, sizeof(five));
  writeBytes(bad, wrong_count);
  EXPECT_NE(readError(bad).find("does not match 5 objects"), std::string::npos) << readError(bad);

  std::vector<char> with_nan = bytes;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(with_nan.data() + kHeaderBytes + (3 + 2) * 32 + 4, &nan, sizeof(nan));
  writeBytes(bad, with_nan);
  EXPECT_NE(readError(bad).find("frame 1, object 2: non-finite y"), std::string::npos)
      << readError(bad);

  std::vector<char> inverted = bytes;
  const float big = 100.0f;
  std::memcpy(inverted.data() + kHeaderBytes + 1 * 32 + 8, &big, sizeof(big));
  writeBytes(bad, inverted);
  EXPECT_NE(readError(bad).find("frame 0, object 1: min > max on z"), std::string::npos)
      << readError(bad);

  std::vector<char> huge_frame_count = bytes;
  const std::int32_t largest = std::numeric_limits<std::int32_t>::max();
  std::memcpy(huge_frame_count.data() + 260, &largest, sizeof(largest));
  writeBytes(bad, huge_frame_count);
  EXPECT_NE(readError(bad).find("frame count 2147483647 is too large"), std::string::npos)
      << readError(bad);

  EXPECT_NE(readError(bad).find(bad.string()), std::string::npos);
  EXPECT_NE(readError(tempFile("missing")).find("cannot open"), std::string::npos);
  std::filesystem::remove(good);
  std::filesystem::remove(bad);
}

// A search that a stop signal may cut short (bf and cpubf return early) is
// never handed on as if whole: findPairs stops with Interrupted, naming where
// the caller says, so a command cannot compare or print part of a search.
TEST(BroadphaseReplay, ASearchUnderAStopSignalStopsInsteadOfReturningPartPairs) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  for (const char* algorithm : {"bf", "cpubf", "sap"}) {
    EXPECT_EXIT(
        {
          const AabbStream stream = smallStream();
          BroadphaseReplay replay(algorithm, stream.world, stream.objects);
          replay.update(stream.frame(0));
          catchInterrupts();
          raise(SIGTERM);
          try {
            replay.findPairs([] { return std::string("frame 0"); });
          } catch (const Interrupted& stop) {
            std::exit(std::string(stop.what()) == "SIGTERM at frame 0" ? 0 : 2);
          }
          std::exit(1);
        },
        ::testing::ExitedWithCode(0), "")
        << algorithm;
  }
}

TEST(BroadphaseReplay, EveryAlgorithmFindsTheTouchingAndOverlappingPairs) {
  const AabbStream stream = smallStream();
  for (const char* algorithm : {"bf", "sap", "sap32", "bvh", "cpubf"}) {
    BroadphaseReplay replay(algorithm, stream.world, stream.objects);
    replay.update(stream.frame(0));
    replay.findPairs();
    EXPECT_EQ(replay.pairs(), (PairList{{0, 1}})) << algorithm;
    replay.update(stream.frame(1));
    replay.findPairs();
    const auto pairs = replay.pairs();
    EXPECT_TRUE(std::find(pairs.begin(), pairs.end(), finders::IndexPair{1, 2}) != pairs.end())
        << algorithm;
  }
}

TEST(AabbStream, WriterRefusesWhatTheReaderWouldNamingFrameAndObject) {
  const auto path = tempFile("unwritable");
  std::filesystem::remove(path);
  constexpr float kInf = std::numeric_limits<float>::infinity();
  for (const Aabb& bad : {Aabb{{kInf, kInf, kInf}, {-kInf, -kInf, -kInf}},
                          Aabb{{0, std::nanf(""), 0}, {1, 1, 1}}, Aabb{{0, 0, 2}, {1, 1, 1}}}) {
    AabbStream stream = smallStream();
    stream.boxes[4] = bad;  // frame 1, object 1
    try {
      writeAabbStream(path, stream);
      FAIL() << "a bad box was written";
    } catch (const AabbStreamError& error) {
      EXPECT_NE(std::string(error.what()).find("frame 1, object 1"), std::string::npos)
          << error.what();
    }
    EXPECT_FALSE(std::filesystem::exists(path));
  }
}

TEST(AabbStream, ReadingADirectoryNamesIt) {
  const auto folder = overlap::testing::scratchPath("stream_folder.aabbs");
  std::filesystem::create_directories(folder);
  EXPECT_NE(readError(folder).find(folder.string() + ": is a directory"), std::string::npos)
      << readError(folder);
  std::filesystem::remove(folder);
}

// Parked boxes (objects out of the simulation) are valid, outside the world,
// and pair with nothing: not the boxes inside, not each other.
TEST(AabbStream, ParkedBoxesAreValidAndPairWithNothing) {
  constexpr int kObjects = 50;
  const Aabb world{{-10, -10, -10}, {10, 10, 10}};
  AabbStream stream;
  stream.scene_name = "parked";
  stream.object_type = "box";
  stream.objects = kObjects;
  stream.stored_frames = 2;
  stream.world = world;
  // Half the objects stand apart along the world's +x face, half are parked;
  // both frames alike.
  for (int frame = 0; frame < 2; ++frame) {
    for (int i = 0; i < kObjects; ++i) {
      const float y = -10.0f + 0.8f * static_cast<float>(i);
      stream.boxes.push_back(i < kObjects / 2 ? Aabb{{9.5f, y, -10}, {10, y + 0.4f, 10}}
                                              : parkedBox(world, i, kObjects));
    }
  }
  const auto path = tempFile("parked");
  writeAabbStream(path, stream);
  const AabbStream read = readAabbStream(path);
  for (int i = kObjects / 2; i < kObjects; ++i) {
    EXPECT_GT(read.frame(1)[static_cast<std::size_t>(i)].min[0], world.max[0]);
  }
  for (const char* algorithm : {"bf", "sap", "sap32", "bvh", "cpubf"}) {
    BroadphaseReplay replay(algorithm, read.world, read.objects);
    for (int frame = 0; frame < 2; ++frame) {
      replay.update(read.frame(frame));
      replay.findPairs();
      EXPECT_TRUE(replay.pairs().empty()) << algorithm << ": " << replay.pairs().size() << " pairs";
    }
  }
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace overlap::physics
