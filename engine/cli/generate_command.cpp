// `overlap generate`: a scene's AABB stream from engine/streams/stream_generator.h's
// model, without Bullet, in the .aabbs layout `overlap pairs` and
// overlap_bench_broadphase --input read.
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "engine/program/program_runner.h"
#include "engine/cli/commands.h"
#include "engine/program/number_options.h"
#include "engine/program/progress.h"
#include "engine/program/scene_options.h"
#include "engine/program/summary_output.h"
#include "engine/program/usage_error.h"
#include "engine/program/wording.h"
#include "engine/runtime/run_summary.h"
#include "engine/streams/recorded_streams.h"
#include "engine/streams/stream_generator.h"
#include "gpu/base/interrupt.h"
#include "gpu/base/stopwatch.h"
#include "physics/aabb_stream.h"

namespace overlap::engine {
namespace {

struct GenerateOptions {
  SceneOptions scene;
  int frames = 16;
  int skip = 0;
  double moving = 1.0;
  std::filesystem::path out;
  bool quiet = false;
};

// Frame by frame into the output: memory for the model and one frame, a
// signal stops it at a frame boundary (the old file kept), and progress is
// shown from the first second.
void generate(const GenerateOptions& options) {
  const physics::SceneConfig config = options.scene.resolve();
  prepareStreamOutput(options.out, config.objects, options.frames);
  const auto start = std::chrono::steady_clock::now();
  std::optional<StreamGenerator> generator;
  try {
    generator.emplace(config, options.frames, options.skip, options.moving);
  } catch (const std::invalid_argument& error) {  // a scene the options cannot build
    throw UsageError(std::string("--") + error.what());
  }
  const physics::AabbStreamHeader& header = generator->header();
  physics::AabbStreamWriter writer(options.out, header);
  const int steps = options.skip + options.frames;
  Progress progress("overlap generate", steps);
  std::vector<physics::Aabb> boxes;
  std::vector<double> step_ms;  // the model's step, frame by frame
  for (int step = 0; step <= steps; ++step) {
    if (step > 0) {
      // Counted as the progress counts them: the frames stepped, 1 to `steps`.
      stopIfInterrupted("frame " + std::to_string(step) + " of " + std::to_string(steps));
      const HostStopwatch watch;
      generator->step();
      step_ms.push_back(watch.ms());
      progress.update(step);
    }
    if (step < options.skip) continue;
    generator->frame(boxes);
    writer.write(boxes);
  }
  progress.finish();
  writer.commit();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fprintf(stderr, "overlap generate: wrote %s (%s, the start and %s) in %.1f s\n",
               oneLine(options.out.string()).c_str(), counted(header.objects, "object").c_str(),
               counted(header.stored_frames - 1, "frame").c_str(), seconds);
  const FrameSpread spread = spreadOf(step_ms);
  printSummary(options.quiet,
               "overlap generate: " + counted(steps, "frame") + " of scene " +
                   std::to_string(config.scene) + ", " + std::to_string(config.objects) +
                   " boxes, the model without Bullet",
               {"frame       median " + threeDigits(spread.median) + " ms, p95 " +
                threeDigits(spread.p95) + ", max " + threeDigits(spread.max) +
                " (the model's step; " + threeDigits(seconds) + " s in all, writing included)"});
}

}  // namespace

void addGenerateCommand(CLI::App& app) {
  auto options = std::make_shared<GenerateOptions>();
  CLI::App* command = app.add_subcommand(
      "generate", "write a scene's AABBs as a Broadmark .aabbs file from a model, without Bullet");
  options->scene.addTo(*command);
  command
      ->add_option("--frames", options->frames,
                   "frames to write, each --frame-time long (F; F + 1 are stored)")
      ->check(wholeNumberIn(1, kMostFrames))
      ->capture_default_str();
  command
      ->add_option("--skip", options->skip,
                   "frames run before the first one stored (e.g. until the pile has formed)")
      ->check(wholeNumberIn(0, kMostFrames))
      ->capture_default_str();
  command
      ->add_option("--moving", options->moving,
                   "share of the boxes that move after the first stored frame; the others keep "
                   "its AABB")
      ->check(realNumberIn(0.0, 1.0))
      ->capture_default_str();
  command->add_option("--out", options->out, "the .aabbs file to write")->required();
  addQuietFlag(*command, options->quiet);
  command->footer(
      "The model (engine/streams/stream_generator.h) moves the scene's boxes like the simulation, "
      "without collisions between them.\nExample:\n"
      "  overlap generate --scene 4 --objects 1000000 --frames 16 --out scene4_1M.aabbs");
  command->callback([options] { generate(*options); });
}

}  // namespace overlap::engine
