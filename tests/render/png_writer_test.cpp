#include <gtest/gtest.h>

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

TEST(EncodePng, GivesAPngThatDecodesPixelForPixel) {
  const Image image = gradient(37, 23);
  const Image read = test_support::decodePng(encodePng(image));
  EXPECT_EQ(read.width, 37);
  EXPECT_EQ(read.height, 23);
  EXPECT_EQ(read.rgba, image.rgba);
}

TEST(EncodePng, WritesNoTimeStampAndEqualImagesGiveEqualBytes) {
  const std::string bytes = encodePng(gradient(8, 8));
  EXPECT_EQ(bytes.substr(1, 3), "PNG");
  EXPECT_EQ(bytes.find("tIME"), std::string::npos);
  EXPECT_EQ(bytes, encodePng(gradient(8, 8)));
  EXPECT_NE(bytes, encodePng(gradient(8, 7)));
}

TEST(EncodePng, MalformedImageThrows) {
  Image short_of_bytes = gradient(4, 4);
  short_of_bytes.rgba.pop_back();
  EXPECT_THROW(encodePng(short_of_bytes), RenderError);
  EXPECT_THROW(encodePng(Image{0, 0, {}}), RenderError);
}

}  // namespace
}  // namespace overlap::render
