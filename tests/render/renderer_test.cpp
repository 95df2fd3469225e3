#include "render/renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "render_test_support.h"

namespace overlap::render {
namespace {

using test_support::countNonBackground;
using test_support::randomBoxes;
using test_support::singleBox;

constexpr float kHalfExtent = 10.0f;

Image renderBoxes(OffscreenRenderer& renderer, const std::vector<BoxInstance>& boxes) {
  return renderer.render({kHalfExtent, boxes});
}

// Mean row of the pixels that are not background: 0 is the top of the image.
double meanForegroundRow(const Image& image) {
  const std::uint32_t background = test_support::backgroundPixel(image);
  double sum = 0.0;
  int count = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      if (test_support::pixelAt(image, x, y) != background) {
        sum += y;
        ++count;
      }
    }
  }
  return count > 0 ? sum / count : -1.0;
}

void expectRenderErrorMentioning(const std::function<void()>& action, const std::string& text) {
  try {
    action();
    ADD_FAILURE() << "no RenderError; expected one mentioning \"" << text << "\"";
  } catch (const RenderError& error) {
    EXPECT_NE(std::string(error.what()).find(text), std::string::npos) << error.what();
  }
}

TEST(OffscreenRenderer, ImageHasTheRequestedSizeAndIsOpaque) {
  OffscreenRenderer renderer(160, 90);
  const Image image = renderBoxes(renderer, randomBoxes(20, kHalfExtent, 1));
  EXPECT_EQ(image.width, 160);
  EXPECT_EQ(image.height, 90);
  ASSERT_EQ(image.rgba.size(), 160u * 90u * 4u);
  for (std::size_t alpha = 3; alpha < image.rgba.size(); alpha += 4) {
    ASSERT_EQ(image.rgba[alpha], 255) << "pixel " << alpha / 4;
  }
}

TEST(OffscreenRenderer, BackgroundIsTheClearColour) {
  OffscreenRenderer renderer(64, 48);
  const Image image = renderBoxes(renderer, {});
  const Eigen::Vector3f expected = backgroundColour() * 255.0f;
  for (int channel = 0; channel < 3; ++channel) {
    EXPECT_NEAR(image.rgba[static_cast<std::size_t>(channel)], expected[channel], 1.0);
  }
}

TEST(OffscreenRenderer, EmptySceneShowsOnlyTheContainerEdges) {
  OffscreenRenderer renderer(200, 150);
  const Image image = renderBoxes(renderer, {});
  const int edge_pixels = countNonBackground(image);
  EXPECT_GT(edge_pixels, 200);  // 12 edges, most of them longer than 50 pixels
  EXPECT_LT(edge_pixels, 200 * 150 / 20);
}

TEST(OffscreenRenderer, MoreBoxesCoverMorePixels) {
  OffscreenRenderer renderer(200, 150);
  const int empty = countNonBackground(renderBoxes(renderer, {}));
  const int few = countNonBackground(renderBoxes(renderer, randomBoxes(10, kHalfExtent, 7)));
  const int many = countNonBackground(renderBoxes(renderer, randomBoxes(200, kHalfExtent, 7)));
  EXPECT_GT(few, empty);
  EXPECT_GT(many, 3 * few);
}

TEST(OffscreenRenderer, SameSceneGivesIdenticalPngBytes) {
  const auto boxes = randomBoxes(300, kHalfExtent, 42);
  OffscreenRenderer renderer(320, 240);
  const std::string first = encodePng(renderBoxes(renderer, boxes));
  const std::string second = encodePng(renderBoxes(renderer, boxes));
  OffscreenRenderer fresh_renderer(320, 240);
  const std::string fresh = encodePng(renderBoxes(fresh_renderer, boxes));

  EXPECT_FALSE(first.empty());
  EXPECT_EQ(first, second);
  EXPECT_EQ(first, fresh);
}

TEST(OffscreenRenderer, TopOfTheContainerIsAtTheTopOfTheImage) {
  OffscreenRenderer renderer(200, 150);
  const double high = meanForegroundRow(renderBoxes(renderer, {singleBox({0, 8, 0}, 3.0f, 1)}));
  const double low = meanForegroundRow(renderBoxes(renderer, {singleBox({0, -8, 0}, 3.0f, 1)}));
  EXPECT_LT(high, low);
}

TEST(OffscreenRenderer, SizeClassesHaveTheirOwnColours) {
  OffscreenRenderer renderer(200, 150, ColourMode::kSizeClass);
  std::vector<Eigen::Vector3f> palette;
  for (int size_class = 0; size_class < kSizeClassCount; ++size_class) {
    palette.push_back(boxColour(ColourMode::kSizeClass, singleBox({0, 0, 0}, 1, size_class)));
  }
  for (int size_class = 0; size_class < kSizeClassCount; ++size_class) {
    const Image image = renderBoxes(renderer, {singleBox({0, 0, 0}, 6.0f, size_class)});
    EXPECT_EQ(test_support::majorityColour(image, palette), size_class);
  }
}

TEST(OffscreenRenderer, ContactModeColoursByContact) {
  OffscreenRenderer renderer(200, 150, ColourMode::kContact);
  const BoxInstance touching = singleBox({0, 0, 0}, 6.0f, 2, true);
  const BoxInstance free = singleBox({0, 0, 0}, 6.0f, 2, false);
  const std::vector<Eigen::Vector3f> palette = {boxColour(ColourMode::kContact, touching),
                                                boxColour(ColourMode::kContact, free)};
  EXPECT_EQ(test_support::majorityColour(renderBoxes(renderer, {touching}), palette), 0);
  EXPECT_EQ(test_support::majorityColour(renderBoxes(renderer, {free}), palette), 1);
}

TEST(OffscreenRenderer, RenderersOfDifferentSizesInterleave) {
  const auto boxes = randomBoxes(50, kHalfExtent, 3);
  OffscreenRenderer wide(120, 60);
  OffscreenRenderer tall(60, 120);
  const Image wide_first = renderBoxes(wide, boxes);
  const Image tall_first = renderBoxes(tall, boxes);
  EXPECT_EQ(renderBoxes(wide, boxes).rgba, wide_first.rgba);
  EXPECT_EQ(renderBoxes(tall, boxes).rgba, tall_first.rgba);
}

TEST(OffscreenRenderer, MovedRendererKeepsRendering) {
  const auto boxes = randomBoxes(50, kHalfExtent, 5);
  OffscreenRenderer original(100, 80);
  const Image before = renderBoxes(original, boxes);
  OffscreenRenderer moved(std::move(original));
  EXPECT_EQ(moved.width(), 100);
  EXPECT_EQ(renderBoxes(moved, boxes).rgba, before.rgba);
}

TEST(OffscreenRenderer, RejectsSizesThatAreNotPositive) {
  expectRenderErrorMentioning([] { OffscreenRenderer(0, 0); }, "0x0");
  expectRenderErrorMentioning([] { OffscreenRenderer(-5, 10); }, "-5x10");
}

TEST(OffscreenRenderer, RejectsSizesAboveTheGlLimit) {
  expectRenderErrorMentioning([] { OffscreenRenderer(100000, 100000); }, "100000x100000");
  expectRenderErrorMentioning([] { OffscreenRenderer(64, 100000); }, "limit");
}

TEST(OffscreenRenderer, RejectsBoxesThatCannotBeDrawn) {
  OffscreenRenderer renderer(32, 32);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  auto boxes = randomBoxes(3, kHalfExtent, 9);
  boxes[1].edge = 0.0f;
  expectRenderErrorMentioning([&] { renderBoxes(renderer, boxes); }, "box 1 has edge length");
  boxes[1].edge = 1.0f;
  boxes[2].centre.y() = nan;
  expectRenderErrorMentioning([&] { renderBoxes(renderer, boxes); }, "box 2 has a non-finite");
  boxes[2].centre.y() = 0.0f;
  boxes[0].size_class = 3;
  expectRenderErrorMentioning([&] { renderBoxes(renderer, boxes); }, "box 0 has size class 3");
  boxes[0].size_class = 0;
  boxes[0].orientation.coeffs().setZero();
  expectRenderErrorMentioning([&] { renderBoxes(renderer, boxes); }, "box 0 has an orientation");
}

TEST(OffscreenRenderer, RejectsContainersThatAreNotPositive) {
  OffscreenRenderer renderer(32, 32);
  expectRenderErrorMentioning([&] { renderer.render({0.0f, {}}); }, "half extent");
  expectRenderErrorMentioning(
      [&] {
        renderer.render({std::numeric_limits<float>::infinity(), {}});
      },
      "half extent");
}

}  // namespace
}  // namespace overlap::render
