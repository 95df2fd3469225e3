// `overlap capture`: keyframe pictures of a scene, like the paper's Figure 1.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "engine/cli/commands.h"
#include "engine/cli/frame_capture.h"
#include "engine/cli/physics_options.h"
#include "engine/cli/world_setup.h"
#include "engine/program/choice_options.h"
#include "engine/program/list_options.h"
#include "engine/program/number_options.h"
#include "engine/program/option_conflicts.h"
#include "engine/program/output_checks.h"
#include "engine/program/program_runner.h"
#include "engine/program/progress.h"
#include "engine/program/scene_options.h"
#include "engine/program/summary_output.h"
#include "engine/program/wording.h"
#include "engine/runtime/game_session.h"
#include "engine/runtime/run_summary.h"

namespace overlap::engine {
namespace {

struct CaptureOptions {
  SceneOptions scene;
  std::optional<std::string> algorithm;  // unset: the box-count rule
  std::vector<int> keyframes = {0, 512, 1024, 2047};
  std::string size = "800x600";
  std::string colour = "size";
  PhysicsOptions physics;
  std::filesystem::path out = "out/capture";
  CLI::Option* size_option = nullptr;
  CLI::Option* old_size_option = nullptr;
  bool quiet = false;
};

render::ColourMode parseColourMode(const std::string& text) {
  return text == "contact" ? render::ColourMode::kContact : render::ColourMode::kSizeClass;
}

void capture(const CaptureOptions& options) {
  const physics::SceneConfig config = options.scene.resolve();
  std::vector<int> keyframes = options.keyframes;
  std::sort(keyframes.begin(), keyframes.end());
  prepareOutputDirectory(options.out, "--out");
  OutputFolder outputs(options.out, "capture");
  outputs.takeOlderListsWhen([](const std::string& entry) { return isKeyframeName(entry); });
  for (const int frame : keyframes) {
    declareOutput(outputs, options.out / pngName(config.scene, frame), "--out");
  }
  const std::unique_ptr<FrameCapture> camera =
      openCapture(outputs, options.out, options.size, parseColourMode(options.colour));
  const ChosenAlgorithm algorithm = chooseAlgorithm(options.algorithm, config.objects);
  GameSession session(makeWorld(config, options.physics.resolve(algorithm.name, config)), {});
  if (!algorithm.default_reason.empty()) {
    std::fprintf(stderr, "overlap: %s\n", algorithm.default_reason.c_str());
  }
  FrameSummary frames(config.frame_time);
  const int last = keyframes.back();
  Progress progress("overlap capture", last + 1);
  auto next = keyframes.begin();
  session.runFrames(last + 1, [&](int frame, const ScheduledFrame& scheduled) {
    frames.add(scheduled.physics.timings.total_ms, scheduled.physics.timings);
    if (frame == *next) {
      camera->capture(session.world(), frame);
      ++next;
    }
    progress.update(frame + 1);
  });
  progress.finish();
  const std::vector<std::string> removed = outputs.commit();
  const std::string wrote = "overlap capture: wrote " +
                            counted(static_cast<long long>(camera->written().size()), "PNG") +
                            " in " + options.out.string() + removedText(removed);
  std::fprintf(stderr, "%s\n", oneLine(wrote).c_str());
  printSummary(options.quiet,
               "overlap capture: " + counted(frames.frames(), "frame") + " of scene " +
                   std::to_string(config.scene) + ", " + std::to_string(config.objects) +
                   " boxes, " + session.world().algorithm() + " (a frame: its physics step)",
               frames.lines());
}

}  // namespace

void addCaptureCommand(CLI::App& app) {
  auto options = std::make_shared<CaptureOptions>();
  CLI::App* command = app.add_subcommand(
      "capture",
      "render keyframes of a scene to PNG (scene<S>_frame<F>.png), after each frame's physics");
  options->scene.addTo(*command);
  addListOption(*command, "--keyframes", options->keyframes, wholeNumberIn(0, kMostFrames),
                "frames to render, comma-separated");
  options->size_option =
      command->add_option("--capture-size", options->size, "PNG size WIDTHxHEIGHT")
          ->capture_default_str();
  // The name this option had before run and capture agreed on one; hidden.
  options->old_size_option = command->add_option("--size", options->size)->group("");
  command->add_option("--colour", options->colour, "colour boxes by size class or by contact")
      ->check(oneOf({"size", "contact"}))
      ->capture_default_str();
  addAlgorithmOption(*command, options->algorithm);
  options->physics.addTo(*command);
  command->add_option("--out", options->out, "output folder")->capture_default_str();
  addQuietFlag(*command, options->quiet);
  command->footer(
      "Example:\n"
      "  overlap capture --scene 3 --objects 1250 --keyframes 0,100,200 --capture-size 400x300 "
      "--out shots\n"
      "A capture replaces the PNGs the last capture wrote in --out, and only those; a folder "
      "that holds a run's outputs is refused.");
  command->parse_complete_callback([options] {
    refuseTogether(options->old_size_option, options->size_option,
                   "--size is --capture-size's old name; give one");
  });
  command->callback([options] { capture(*options); });
}

}  // namespace overlap::engine
