#include "engine/cli/frame_capture.h"

#include <chrono>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "engine/program/usage_error.h"
#include "gpu/base/interrupt.h"
#include "render/capture_options.h"

namespace overlap::engine {
namespace {

int renderSizeClass(physics::SizeClass size_class) {
  switch (size_class) {
    case physics::SizeClass::kSmall:
      return 0;
    case physics::SizeClass::kLarge:
      return 2;
    case physics::SizeClass::kUnit:
    case physics::SizeClass::kAverage:
      return 1;
  }
  return 1;
}

}  // namespace

FrameCapture::FrameCapture(OutputFolder& outputs, const std::filesystem::path& folder, int width,
                           int height, render::ColourMode mode)
    : outputs_(outputs), folder_(folder), renderer_(width, height, mode) {}

bool isKeyframeName(const std::string& name) {
  // scene[0-9]+_frame[0-9]{4,}.png, read by hand (std::regex recurses per
  // character: a long name from a list would overflow the stack).
  const auto digits = [&name](std::size_t at) {
    std::size_t end = at;
    while (end < name.size() && name[end] >= '0' && name[end] <= '9') ++end;
    return end - at;
  };
  constexpr std::string_view kScene = "scene", kFrame = "_frame", kPng = ".png";
  if (!name.starts_with(kScene)) return false;
  const std::size_t scene_digits = digits(kScene.size());
  const std::size_t frame_at = kScene.size() + scene_digits;
  if (scene_digits == 0 || name.compare(frame_at, kFrame.size(), kFrame) != 0) return false;
  const std::size_t frame_digits = digits(frame_at + kFrame.size());
  return frame_digits >= 4 &&
         name.size() == frame_at + kFrame.size() + frame_digits + kPng.size() &&
         name.ends_with(kPng);
}

std::string pngName(int scene, int frame) {
  char name[64];
  std::snprintf(name, sizeof(name), "scene%d_frame%04d.png", scene, frame);
  return name;
}

std::unique_ptr<FrameCapture> openCapture(OutputFolder& outputs,
                                          const std::filesystem::path& folder,
                                          const std::string& size_text, render::ColourMode mode) {
  try {
    const render::ImageSize size = render::parseImageSize(size_text);
    return std::make_unique<FrameCapture>(outputs, folder, size.width, size.height, mode);
  } catch (const render::ImageSizeError& error) {
    throw UsageError("--capture-size " + size_text + ": " + error.what());
  } catch (const render::RenderError&) {
    throw;  // OSMesa failing is the program's failure, not the value's
  } catch (const Interrupted&) {
    throw;  // a stop during the renderer's start
  } catch (const std::runtime_error& error) {
    throw UsageError(std::string("--capture-size: ") + error.what());
  }
}

double FrameCapture::capture(const physics::PhysicsWorld& world, int frame) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<render::BoxInstance> boxes;
  for (const physics::BoxPose& pose : world.boxPoses()) {
    boxes.push_back(
        render::BoxInstance{Eigen::Vector3f(pose.centre[0], pose.centre[1], pose.centre[2]),
                            Eigen::Quaternionf(pose.orientation[3], pose.orientation[0],
                                               pose.orientation[1], pose.orientation[2]),
                            pose.edge, renderSizeClass(pose.size_class), pose.in_contact});
  }
  const render::SceneView view{static_cast<float>(world.layout().half_extent), boxes};
  const std::filesystem::path path = folder_ / pngName(world.config().scene, frame);
  OutputFile& png = outputs_.open(path);
  png.write(render::encodePng(renderer_.render(view)));
  png.finish();  // closed now: a long run keeps no descriptor per picture
  written_.push_back(path);
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace overlap::engine
