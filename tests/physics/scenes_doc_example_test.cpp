// docs/SCENES.md documents the .aabbs layout with a hex dump of a small
// file.  This test reads that dump out of the document (the xxd lines
// between its two marker lines), hands the bytes to the project's reader and
// checks the values the document states, so the document and the code
// cannot drift apart.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "physics/aabb_stream.h"
#include "physics/broadphase_replay.h"
#include "tests/scratch_path.h"

namespace overlap::physics {
namespace {

constexpr const char* kBegin = "<!-- aabbs-example begin -->";
constexpr const char* kEnd = "<!-- aabbs-example end -->";

// The bytes of the xxd lines ("OFFSET: hhhh hhhh ...  ascii") between the
// markers; each line's offset must be the count of bytes read before it.
std::vector<char> exampleBytes(const std::filesystem::path& document) {
  std::ifstream in(document);
  EXPECT_TRUE(in) << "cannot open " << document;
  std::vector<char> bytes;
  bool inside = false;
  bool ended = false;
  for (std::string line; std::getline(in, line);) {
    if (line == kBegin) {
      inside = true;
    } else if (line == kEnd) {
      ended = inside;
      break;
    } else if (inside && line.size() > 10 && line[8] == ':') {
      EXPECT_EQ(std::stoul(line.substr(0, 8), nullptr, 16), bytes.size()) << line;
      const std::string hex = line.substr(10, line.find("  ", 10) - 10);
      std::string digits;
      for (const char c : hex) {
        if (c != ' ') digits += c;
      }
      EXPECT_EQ(digits.size() % 2, 0u) << line;
      for (std::size_t i = 0; i + 1 < digits.size(); i += 2) {
        bytes.push_back(static_cast<char>(std::stoul(digits.substr(i, 2), nullptr, 16)));
      }
    }
  }
  EXPECT_TRUE(ended) << document << " lacks the lines " << kBegin << " and " << kEnd;
  return bytes;
}

void expectBox(const Aabb& box, const Aabb& expected, const std::string& what) {
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_EQ(box.min[axis], expected.min[axis]) << what << " min, axis " << axis;
    EXPECT_EQ(box.max[axis], expected.max[axis]) << what << " max, axis " << axis;
  }
}

TEST(ScenesDocExample, TheReaderAcceptsTheDocumentedFileAndGetsTheDocumentedValues) {
  const std::vector<char> bytes =
      exampleBytes(std::filesystem::path(OVERLAP_SOURCE_DIR) / "docs" / "SCENES.md");
  ASSERT_EQ(bytes.size(), 432u) << "304 header bytes + 32 x 2 boxes x 2 stored frames";
  const std::filesystem::path file = overlap::testing::scratchPath("scenes_doc_example.aabbs");
  {
    std::ofstream out(file, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }

  const AabbStream stream = readAabbStream(file);
  EXPECT_EQ(stream.scene_name, "docs/SCENES.md example");
  EXPECT_EQ(stream.object_type, "box");
  EXPECT_EQ(stream.objects, 2);
  EXPECT_EQ(stream.stored_frames, 2) << "F = 1: the start and one frame";
  expectBox(stream.world, Aabb{{-4, -4, -4}, {4, 4, 4}}, "world");
  expectBox(stream.frame(0)[0], Aabb{{0, 0, 0}, {1, 1, 1}}, "frame 0, box 0");
  expectBox(stream.frame(0)[1], Aabb{{0.5f, 0, 0}, {1.5f, 1, 1}}, "frame 0, box 1");
  expectBox(stream.frame(1)[0], Aabb{{0, -0.25f, 0}, {1, 0.75f, 1}}, "frame 1, box 0");
  expectBox(stream.frame(1)[1], Aabb{{2, 0, 0}, {3, 1, 1}}, "frame 1, box 1");

  // The document says `overlap pairs --algo bf` finds 0-1 in frame 0 and nothing in frame 1.
  BroadphaseReplay replay("bf", stream.world, stream.objects);
  const std::vector<PairList> expected_pairs = {{{0, 1}}, {}};
  for (int frame = 0; frame < stream.stored_frames; ++frame) {
    replay.update(stream.frame(frame));
    replay.findPairs();
    EXPECT_EQ(replay.pairs(), expected_pairs[frame]) << "frame " << frame;
  }

  // The writer gives back the documented bytes: the padding and zeros are the layout's.
  writeAabbStream(file, stream);
  EXPECT_EQ(overlap::testing::fileBytes(file), bytes);
  std::filesystem::remove(file);
}

}  // namespace
}  // namespace overlap::physics
