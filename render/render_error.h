// The error types the render module throws.
//
// Every failure (bad input, OSMesa or OpenGL refusing, a PNG that cannot be
// written) is reported as a RenderError whose message names the input and the
// problem, so a capture never silently produces a black or partial image.
#pragma once

#include <stdexcept>

namespace overlap::render {

struct RenderError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The image size asked for is one this OpenGL cannot render (not positive, or
// above its limit): the caller's value is wrong, not the renderer.
struct ImageSizeError : RenderError {
  using RenderError::RenderError;
};

}  // namespace overlap::render
