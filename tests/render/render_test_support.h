// Helpers the render tests share: seeded scenes, pixel statistics, PNG
// read-back and a scratch directory.
#pragma once

#include <png.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "render/renderer.h"

namespace overlap::render::test_support {

// n boxes of edge 1 scattered in [-half + 1, half - 1]^3 with random
// orientations; the same seed gives the same boxes.
inline std::vector<BoxInstance> randomBoxes(int n, float half_extent, std::uint32_t seed) {
  std::mt19937 engine(seed);
  const auto unit = [&engine] { return static_cast<float>(engine()) / 4294967296.0f; };
  const auto coordinate = [&] { return (2.0f * unit() - 1.0f) * (half_extent - 1.0f); };
  std::vector<BoxInstance> boxes;
  for (int i = 0; i < n; ++i) {
    const Eigen::Quaternionf orientation(unit() - 0.5f, unit() - 0.5f, unit() - 0.5f,
                                         unit() - 0.5f);
    boxes.push_back({Eigen::Vector3f(coordinate(), coordinate(), coordinate()),
                     orientation.normalized(), 1.0f, i % kSizeClassCount, i % 2 == 0});
  }
  return boxes;
}

inline BoxInstance singleBox(Eigen::Vector3f centre, float edge, int size_class,
                             bool in_contact = false) {
  return {centre, Eigen::Quaternionf(Eigen::AngleAxisf(0.3f, Eigen::Vector3f::UnitY())), edge,
          size_class, in_contact};
}

inline std::uint32_t pixelAt(const Image& image, int x, int y) {
  const auto* p = &image.rgba[4 * (static_cast<std::size_t>(y) * image.width + x)];
  return p[0] | p[1] << 8 | p[2] << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

// The image's corner pixel: the camera keeps the scene off the corners.
inline std::uint32_t backgroundPixel(const Image& image) {
  return pixelAt(image, 0, 0);
}

inline int countNonBackground(const Image& image) {
  const std::uint32_t background = backgroundPixel(image);
  int count = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) count += pixelAt(image, x, y) != background;
  }
  return count;
}

// Which of the candidate colours most non-background pixels show.  Lighting
// scales a box's colour, so a pixel is matched by its direction in RGB space.
inline int majorityColour(const Image& image, const std::vector<Eigen::Vector3f>& candidates) {
  const std::uint32_t background = backgroundPixel(image);
  std::vector<int> votes(candidates.size(), 0);
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const std::uint32_t pixel = pixelAt(image, x, y);
      if (pixel == background) continue;
      const Eigen::Vector3f colour =
          Eigen::Vector3f(static_cast<float>(pixel & 0xff), static_cast<float>(pixel >> 8 & 0xff),
                          static_cast<float>(pixel >> 16 & 0xff))
              .normalized();
      std::size_t closest = 0;
      for (std::size_t i = 1; i < candidates.size(); ++i) {
        if (colour.dot(candidates[i].normalized()) > colour.dot(candidates[closest].normalized())) {
          closest = i;
        }
      }
      ++votes[closest];
    }
  }
  return static_cast<int>(std::max_element(votes.begin(), votes.end()) - votes.begin());
}

// Decodes PNG file bytes (encodePng's) as RGBA.
inline Image decodePng(const std::string& bytes) {
  png_image description{};
  description.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&description, bytes.data(), bytes.size())) {
    throw std::runtime_error(std::string("cannot read the PNG: ") + description.message);
  }
  description.format = PNG_FORMAT_RGBA;
  Image image{static_cast<int>(description.width), static_cast<int>(description.height), {}};
  image.rgba.resize(PNG_IMAGE_SIZE(description));
  if (!png_image_finish_read(&description, nullptr, image.rgba.data(), 0, nullptr)) {
    throw std::runtime_error(std::string("cannot decode the PNG: ") + description.message);
  }
  return image;
}

}  // namespace overlap::render::test_support
