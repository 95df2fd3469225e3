// Offscreen pictures of a scene: the boxes, lit and coloured, inside the
// container's edges, rendered by OSMesa (Mesa's software OpenGL, no display
// and no GPU needed) through an OpenGL 3.3 core context.
//
// The boxes are drawn instanced, one cube mesh for all, each coloured by its
// size class or by whether it touches anything (ColourMode).  The container's
// interior is drawn as its 12 edges; the walls themselves are left out so the
// boxes stay visible.  The camera is fixed (see camera.h), so consecutive
// frames of a run line up into a readable animation.
//
// Invariants: a render is deterministic (the same renderer size, mode and
// scene give the same pixels); an Image is either complete or not returned at
// all: every OSMesa or GL failure, and every malformed input, throws a
// RenderError naming it (RendererOutOfMemory where memory ran out).  An OffscreenRenderer owns one
// GL context and must be used from one thread at a time (Mesa contexts are per thread).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "render/render_error.h"

namespace overlap::render {

enum class ColourMode { kSizeClass, kContact };

inline constexpr int kSizeClassCount = 3;  // 0 small, 1 average, 2 large

struct BoxInstance {
  Eigen::Vector3f centre;
  Eigen::Quaternionf orientation;  // need not be exactly unit: it is normalised
  float edge;                      // edge length in metres (a cube of side edge)
  int size_class;                  // 0 small, 1 average, 2 large
  bool in_contact;
};

struct SceneView {
  float interior_half_extent;  // L/2: the interior is [-L/2, L/2]^3
  std::span<const BoxInstance> boxes;
};

// RGBA, 8 bits per channel, rows top first (as image files store them).
struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba;
};

// Colours before lighting, each channel in [0, 1].  A lit face shows the
// box's colour scaled by a factor in [0.3, 1].  boxColour needs a size class
// in 0..2 (render() checks every box before drawing).
Eigen::Vector3f backgroundColour();
Eigen::Vector3f boxColour(ColourMode mode, const BoxInstance& box);

class OffscreenRenderer {
 public:
  // Creates the GL context and everything the draws need.  Throws
  // ImageSizeError if the size is not positive or above this OpenGL's limit,
  // RendererOutOfMemory (a std::bad_alloc) if OSMesa cannot give an
  // OpenGL 3.3 core context or the framebuffer's storage.
  OffscreenRenderer(int width, int height, ColourMode mode = ColourMode::kSizeClass);
  ~OffscreenRenderer();
  // A moved-from renderer may only be destroyed or assigned to.
  OffscreenRenderer(OffscreenRenderer&&) noexcept;
  OffscreenRenderer& operator=(OffscreenRenderer&&) noexcept;

  // Throws RenderError for a box that cannot be drawn (non-finite or
  // non-positive sizes, a size class outside 0..2) naming its index, or for
  // any GL error while drawing.
  Image render(const SceneView& view);

  int width() const;
  int height() const;

 private:
  struct Context;
  std::unique_ptr<Context> context_;
};

// An 8-bit RGBA PNG file's bytes, with no time stamp, so equal images give
// equal files; the caller writes them (engine/: gpu/base/output_file.h).
// Throws RenderError for a malformed image.
std::string encodePng(const Image& image);

}  // namespace overlap::render
