// `overlap run`: steps a scene and writes frames.csv and summary.json.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "engine/cli_errors.h"
#include "engine/commands.h"
#include "engine/frame_capture.h"
#include "engine/machine_info.h"
#include "engine/progress.h"
#include "engine/scene_options.h"
#include "engine/statistics.h"
#include "physics/world.h"
#include "render/capture_options.h"

namespace overlap::engine {
namespace {

struct RunOptions {
  SceneOptions scene;
  std::string algorithm = "bvh";
  int frames = 2048;
  int substeps = 0;
  bool ccd = false;
  std::filesystem::path out = "out";
  int capture_every = 0;  // 0: no pictures
  std::string capture_size = "800x600";
};

// The timing columns of frames.csv, with how to read each from a report.
struct TimingColumn {
  const char* name;
  double physics::FrameTimings::*field;
};
constexpr TimingColumn kTimingColumns[] = {
    {"update_ms", &physics::FrameTimings::update_ms},
    {"broadphase_ms", &physics::FrameTimings::broadphase_ms},
    {"narrowphase_ms", &physics::FrameTimings::narrowphase_ms},
    {"solver_ms", &physics::FrameTimings::solver_ms},
    {"integrate_ms", &physics::FrameTimings::integrate_ms},
    {"total_ms", &physics::FrameTimings::total_ms},
};

std::string framesCsv(const std::vector<physics::FrameReport>& reports,
                      const std::vector<double>& render_ms) {
  std::ostringstream csv;
  csv << "frame";
  for (const auto& column : kTimingColumns) csv << ',' << column.name;
  csv << ",render_ms,pairs,escaped,sunk,max_penetration,removed\n";
  csv << std::setprecision(6);
  for (std::size_t i = 0; i < reports.size(); ++i) {
    const physics::FrameReport& report = reports[i];
    csv << report.frame;
    for (const auto& column : kTimingColumns) csv << ',' << report.timings.*column.field;
    csv << ',' << render_ms[i] << ',' << report.pairs << ',' << report.escaped << ',' << report.sunk
        << ',' << report.max_penetration << ',' << report.removed_from_simulation << '\n';
  }
  return csv.str();
}

nlohmann::json summarize(const RunOptions& options, const physics::SceneConfig& config,
                         const physics::PhysicsWorld& world,
                         const std::vector<physics::FrameReport>& reports, double wall_seconds) {
  nlohmann::json parameters = toJson(config);
  parameters["algorithm_requested"] = options.algorithm;
  parameters["algorithm"] = world.algorithm();
  parameters["frames"] = options.frames;
  parameters["substeps"] = world.substeps();
  parameters["ccd"] = options.ccd;
  parameters["capture_every"] = options.capture_every;

  nlohmann::json timings;
  for (const auto& column : kTimingColumns) {
    std::vector<double> values;
    values.reserve(reports.size());
    for (const auto& report : reports) values.push_back(report.timings.*column.field);
    timings[column.name] = {{"mean", mean(values)}, {"median", median(values)}};
  }
  nlohmann::json errors = {
      {"escaped_max", 0}, {"sunk_max", 0}, {"max_penetration", 0.0}, {"removed_max", 0}};
  std::vector<double> pairs;
  for (const auto& report : reports) {
    errors["escaped_max"] = std::max(errors["escaped_max"].get<int>(), report.escaped);
    errors["sunk_max"] = std::max(errors["sunk_max"].get<int>(), report.sunk);
    errors["removed_max"] =
        std::max(errors["removed_max"].get<int>(), report.removed_from_simulation);
    errors["max_penetration"] =
        std::max(errors["max_penetration"].get<double>(), report.max_penetration);
    pairs.push_back(report.pairs);
  }
  errors["escaped_final"] = reports.back().escaped;
  errors["sunk_final"] = reports.back().sunk;

  std::ostringstream hash;
  hash << std::hex << std::setw(16) << std::setfill('0') << world.stateHash();
  return {{"command", "run"},
          {"parameters", parameters},
          {"layout",
           {{"interior_half_extent", world.layout().half_extent},
            {"wall_thickness", world.layout().wall_thickness}}},
          {"timings_ms", timings},
          {"pairs", {{"mean", mean(pairs)}, {"median", median(pairs)}}},
          {"errors", errors},
          {"state_hash", hash.str()},
          {"wall_seconds", wall_seconds},
          {"machine", machineInfo()}};
}

void run(const RunOptions& options) {
  const physics::SceneConfig config = options.scene.resolve();
  prepareOutputDirectory(options.out, "--out");
  std::unique_ptr<FrameCapture> camera;
  if (options.capture_every > 0) {
    render::ImageSize size{};
    try {
      size = render::parseImageSize(options.capture_size);
    } catch (const std::runtime_error& error) {
      throw UsageError(std::string("--capture-size: ") + error.what());
    }
    prepareOutputDirectory(options.out / "frames", "--out");
    camera = std::make_unique<FrameCapture>(options.out / "frames", size.width, size.height,
                                            render::ColourMode::kSizeClass);
  }

  physics::WorldOptions world_options{options.algorithm, options.substeps, options.ccd};
  std::unique_ptr<physics::PhysicsWorld> world;
  try {
    world = std::make_unique<physics::PhysicsWorld>(config, world_options);
  } catch (const std::invalid_argument& error) {
    throw UsageError(std::string("--") + error.what());
  }
  if (!world->algorithmNotice().empty()) {
    std::fprintf(stderr, "overlap: %s\n", world->algorithmNotice().c_str());
  }

  Progress progress("overlap run", options.frames);
  std::vector<physics::FrameReport> reports;
  std::vector<double> render_ms(static_cast<std::size_t>(options.frames), 0.0);
  reports.reserve(static_cast<std::size_t>(options.frames));
  for (int frame = 0; frame < options.frames; ++frame) {
    reports.push_back(world->stepFrame());
    if (camera && frame % options.capture_every == 0) {
      render_ms[static_cast<std::size_t>(frame)] = camera->capture(*world, frame);
    }
    progress.update(frame + 1);
  }
  progress.finish();

  writeFileAtomically(options.out / "frames.csv", framesCsv(reports, render_ms));
  writeFileAtomically(
      options.out / "summary.json",
      summarize(options, config, *world, reports, progress.seconds()).dump(2) + "\n");
}

}  // namespace

void addRunCommand(CLI::App& app) {
  auto options = std::make_shared<RunOptions>();
  CLI::App* command = app.add_subcommand("run", "step a scene and write frames.csv, summary.json");
  options->scene.addTo(*command);
  addAlgorithmOption(*command, options->algorithm);
  command->add_option("--frames", options->frames, "frames of 1/30 s")
      ->check(CLI::Range(1, 1'000'000))
      ->capture_default_str();
  command
      ->add_option("--substeps", options->substeps,
                   "fixed steps per frame (default: 2 for scenes 1-2, 8 for 3-4)")
      ->check(CLI::Range(1, 1000));
  command->add_flag("--ccd", options->ccd, "Bullet's continuous collision detection on every box");
  command->add_option("--out", options->out, "output folder")->capture_default_str();
  command
      ->add_option("--capture-every", options->capture_every,
                   "write every K-th frame as a PNG under OUT/frames (0: none)")
      ->check(CLI::NonNegativeNumber);
  command->add_option("--capture-size", options->capture_size, "captured image size WxH")
      ->capture_default_str();
  command->callback([options] { run(*options); });
}

}  // namespace overlap::engine
