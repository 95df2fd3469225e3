// The one error type the render module throws.
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

}  // namespace overlap::render
