// Frame capture: pictures of a running scene, written as PNG files named
// with the scene and the frame (scene4_frame0512.png), as outputs of the
// run's OutputFolder (published with the rest of the run).  Rendering happens on
// the main thread after the frame's physics and is timed on its own, never
// inside the physics timings.  OSMesa runs in a process of its own
// (render/renderer_process.h): where it runs out of memory the run ends
// with std::bad_alloc, never a signal.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "gpu/base/output_file.h"
#include "physics/world.h"
#include "render/renderer_process.h"

namespace overlap::engine {

// Whether `name` (relative to a folder) is one a capture writes there: a
// keyframe's PNG at the top (scene4_frame0512.png), as a run folder's list
// written before it named its subcommand tells a capture's folder by.
bool isKeyframeName(const std::string& name);

class FrameCapture {
 public:
  // Throws render::RenderError if no OSMesa context of that size can be made.
  FrameCapture(OutputFolder& outputs, const std::filesystem::path& folder, int width, int height,
               render::ColourMode mode);

  // Renders the world as it is now and writes it as `frame`; returns the
  // milliseconds the render and the PNG took.
  double capture(const physics::PhysicsWorld& world, int frame);

  // Every PNG written so far, in order.
  const std::vector<std::filesystem::path>& written() const { return written_; }

 private:
  OutputFolder& outputs_;
  std::filesystem::path folder_;
  render::RendererProcess renderer_;  // OSMesa in a process of its own
  std::vector<std::filesystem::path> written_;
};

// The PNG name of `frame` of `scene`.
std::string pngName(int scene, int frame);

// Parses a --capture-size text (WIDTHxHEIGHT) and opens a camera writing into
// `folder`, through `outputs`.  A malformed size, or one this OpenGL cannot render, is a
// UsageError naming the option and the value; OSMesa failing is not.
std::unique_ptr<FrameCapture> openCapture(OutputFolder& outputs,
                                          const std::filesystem::path& folder,
                                          const std::string& size_text, render::ColourMode mode);

}  // namespace overlap::engine
