// The error types the render module throws.
//
// Every failure (bad input, OSMesa or OpenGL refusing, a PNG that cannot be
// written) is reported as a RenderError whose message names the input and the
// problem, so a capture never silently produces a black or partial image.
#pragma once

#include <new>
#include <stdexcept>
#include <string>
#include <utility>

namespace overlap::render {

struct RenderError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The image size asked for is one this OpenGL cannot render (not positive, or
// above its limit): the caller's value is wrong, not the renderer.
struct ImageSizeError : RenderError {
  using RenderError::RenderError;
};

// OSMesa ran out of memory: it gave no context or framebuffer, or the
// renderer's process died (render/renderer_process.h), as OSMesa does when
// an allocation fails.  A std::bad_alloc, reported as running out of
// memory; what() says where.
struct RendererOutOfMemory : std::bad_alloc {
  explicit RendererOutOfMemory(std::string why) : why_(std::move(why)) {}
  const char* what() const noexcept override { return why_.c_str(); }

 private:
  std::string why_;
};

}  // namespace overlap::render
