#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "render/renderer.h"
#include "render_test_support.h"

namespace overlap::render {
namespace {

// A small image whose every pixel differs, so a transposed or flipped write
// would show.
Image gradient(int width, int height) {
  Image image{width, height, {}};
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      image.rgba.insert(image.rgba.end(),
                        {static_cast<std::uint8_t>(x * 7), static_cast<std::uint8_t>(y * 11),
                         static_cast<std::uint8_t>(x + y), 255});
    }
  }
  return image;
}

TEST(WritePng, WritesAPngThatReadsBackPixelForPixel) {
  const test_support::ScratchDirectory scratch("read_back");
  const Image image = gradient(37, 23);
  writePng(image, scratch.path() / "gradient.png");
  const Image read = test_support::readPng(scratch.path() / "gradient.png");
  EXPECT_EQ(read.width, 37);
  EXPECT_EQ(read.height, 23);
  EXPECT_EQ(read.rgba, image.rgba);
}

TEST(WritePng, WritesNoTimeStampAndLeavesNoTemporaryFile) {
  const test_support::ScratchDirectory scratch("no_time");
  writePng(gradient(8, 8), scratch.path() / "image.png");
  EXPECT_EQ(test_support::fileBytes(scratch.path() / "image.png").find("tIME"), std::string::npos);
  int files = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(scratch.path())) {
    ++files;
  }
  EXPECT_EQ(files, 1);
}

TEST(WritePng, ReplacesAnExistingFile) {
  const test_support::ScratchDirectory scratch("replace");
  const auto path = scratch.path() / "image.png";
  writePng(gradient(40, 30), path);
  writePng(gradient(5, 4), path);
  EXPECT_EQ(test_support::readPng(path).rgba, gradient(5, 4).rgba);
}

TEST(WritePng, UnwritablePathThrowsNamingItAndLeavesNoFile) {
  const test_support::ScratchDirectory scratch("unwritable");
  const auto path = scratch.path() / "no_such_directory" / "image.png";
  try {
    writePng(gradient(4, 4), path);
    ADD_FAILURE() << "writing to " << path << " did not throw";
  } catch (const RenderError& error) {
    EXPECT_NE(std::string(error.what()).find(path.string()), std::string::npos) << error.what();
  }
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_TRUE(std::filesystem::is_empty(scratch.path()));
}

TEST(WritePng, MalformedImageThrowsAndWritesNothing) {
  const test_support::ScratchDirectory scratch("malformed");
  Image short_of_bytes = gradient(4, 4);
  short_of_bytes.rgba.pop_back();
  EXPECT_THROW(writePng(short_of_bytes, scratch.path() / "a.png"), RenderError);
  EXPECT_THROW(writePng(Image{0, 0, {}}, scratch.path() / "b.png"), RenderError);
  EXPECT_TRUE(std::filesystem::is_empty(scratch.path()));
}

}  // namespace
}  // namespace overlap::render
