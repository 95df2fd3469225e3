// `overlap run`: steps a scene through the frame scheduler and writes
// frames.csv, summary.json and timeline.json.
#include <oneapi/tbb/global_control.h>

#include <cstdio>
#include <filesystem>
#include <functional>
#include <iomanip>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <vector>

#include "engine/cli_errors.h"
#include "engine/commands.h"
#include "engine/frame_capture.h"
#include "engine/frame_scheduler.h"
#include "engine/machine_info.h"
#include "engine/physics_options.h"
#include "engine/progress.h"
#include "engine/scene_options.h"
#include "engine/statistics.h"
#include "physics/atomic_file.h"
#include "physics/world.h"
#include "render/capture_options.h"

namespace overlap::engine {
namespace {

struct RunOptions {
  SceneOptions scene;
  std::string algorithm = "gpubf";
  int frames = 2048;
  PhysicsOptions physics;
  bool compare_sync = false;
  int threads = 0;  // 0: every hardware thread
  SchedulerOptions scheduler;
  std::filesystem::path out = "out";
  int capture_every = 0;  // 0: no pictures
  std::string capture_size = "800x600";
};

struct FrameRow {
  ScheduledFrame frame;
  double render_ms = 0;
};

// frames.csv's numeric columns, each with how to read it from a row.
struct Column {
  const char* name;
  std::function<double(const FrameRow&)> value;
  bool timing;  // summarised with mean and median in summary.json
};

const std::vector<Column>& columns() {
  using R = const FrameRow&;
  static const std::vector<Column> kColumns = {
      {"update_ms", [](R r) { return r.frame.physics.timings.update_ms; }, true},
      {"broadphase_ms", [](R r) { return r.frame.physics.timings.broadphase_ms; }, true},
      {"narrowphase_ms", [](R r) { return r.frame.physics.timings.narrowphase_ms; }, true},
      {"solver_ms", [](R r) { return r.frame.physics.timings.solver_ms; }, true},
      {"integrate_ms", [](R r) { return r.frame.physics.timings.integrate_ms; }, true},
      {"total_ms", [](R r) { return r.frame.physics.timings.total_ms; }, true},
      {"tasks_ms", [](R r) { return r.frame.physics.timings.frame_work_ms; }, true},
      {"sound_ms", [](R r) { return r.frame.sound_ms; }, true},
      {"ai_ms", [](R r) { return r.frame.ai_ms; }, true},
      {"search_ms", [](R r) { return r.frame.search_ms; }, true},
      {"join_ms", [](R r) { return r.frame.physics.timings.join_ms; }, true},
      {"overlap_efficiency", [](R r) { return r.frame.overlap_efficiency; }, true},
      {"render_ms", [](R r) { return r.render_ms; }, true},
      {"pairs", [](R r) { return r.frame.physics.pairs; }, false},
      {"escaped", [](R r) { return r.frame.physics.escaped; }, false},
      {"sunk", [](R r) { return r.frame.physics.sunk; }, false},
      {"max_penetration", [](R r) { return r.frame.physics.max_penetration; }, false},
      {"removed", [](R r) { return r.frame.physics.removed_from_simulation; }, false},
      {"kinetic_energy", [](R r) { return r.frame.physics.kinetic_energy; }, false},
      {"potential_energy", [](R r) { return r.frame.physics.potential_energy; }, false},
      {"substeps", [](R r) { return r.frame.physics.substeps; }, false},
      {"ccd_bodies", [](R r) { return r.frame.physics.ccd_bodies; }, false},
      {"sleeping", [](R r) { return r.frame.physics.sleeping; }, false},
      {"fastest_speed", [](R r) { return r.frame.physics.fastest_speed; }, false},
  };
  return kColumns;
}

std::string framesCsv(const std::vector<FrameRow>& rows) {
  std::ostringstream csv;
  csv << "frame";
  for (const Column& column : columns()) csv << ',' << column.name;
  csv << '\n' << std::setprecision(6);
  for (const FrameRow& row : rows) {
    csv << row.frame.physics.frame;
    for (const Column& column : columns()) csv << ',' << column.value(row);
    csv << '\n';
  }
  return csv.str();
}

nlohmann::json columnStatistics(const std::vector<FrameRow>& rows, bool timing) {
  nlohmann::json statistics;
  for (const Column& column : columns()) {
    if (column.timing != timing) continue;
    std::vector<double> values;
    for (const FrameRow& row : rows) values.push_back(column.value(row));
    statistics[column.name] = {{"mean", mean(values)},
                               {"median", median(values)},
                               {"max", *std::max_element(values.begin(), values.end())}};
  }
  return statistics;
}

std::string hex(std::uint64_t value) {
  std::ostringstream text;
  text << std::hex << std::setw(16) << std::setfill('0') << value;
  return text.str();
}

struct RunResult {
  std::vector<FrameRow> rows;
  std::string algorithm;
  std::uint64_t state_hash = 0;
  std::uint64_t sound_checksum = 0;
  std::uint64_t ai_checksum = 0;
  double seconds = 0;
  physics::SceneLayout layout;
};

// One whole run; `camera` and `timeline` may be null (the sync half of --compare-sync).
RunResult runOnce(const RunOptions& options, const physics::SceneConfig& config,
                  const SchedulerOptions& scheduler_options, FrameCapture* camera,
                  Timeline& timeline, const char* label) {
  std::unique_ptr<physics::PhysicsWorld> world;
  try {
    world = std::make_unique<physics::PhysicsWorld>(
        config, options.physics.resolve(options.algorithm, config));
  } catch (const std::invalid_argument& error) {
    throw UsageError(std::string("--") + error.what());
  }
  if (!world->algorithmNotice().empty()) {
    std::fprintf(stderr, "overlap: %s\n", world->algorithmNotice().c_str());
  }
  FrameScheduler scheduler(*world, scheduler_options, timeline);
  RunResult result;
  Progress progress(label, options.frames);
  for (int frame = 0; frame < options.frames; ++frame) {
    FrameRow row{scheduler.runFrame()};
    if (camera != nullptr && frame % options.capture_every == 0) {
      row.render_ms = camera->capture(*world, frame);
    }
    result.rows.push_back(row);
    progress.update(frame + 1);
  }
  progress.finish();
  scheduler.close();
  result.algorithm = world->algorithm();
  result.state_hash = world->stateHash();
  result.sound_checksum = scheduler.soundChecksum();
  result.ai_checksum = scheduler.aiChecksum();
  result.seconds = progress.seconds();
  result.layout = world->layout();
  return result;
}

nlohmann::json summarize(const RunOptions& options, const physics::SceneConfig& config,
                         const RunResult& run) {
  nlohmann::json parameters = toJson(config);
  parameters["algorithm_requested"] = options.algorithm;
  parameters["algorithm"] = run.algorithm;
  parameters["frames"] = options.frames;
  parameters.update(toJson(options.physics.resolve(options.algorithm, config)));
  parameters["sync"] = options.scheduler.sync;
  parameters["threads"] = options.threads;
  parameters["tasks"] = options.scheduler.tasks;
  parameters["voices"] = options.scheduler.sound.voices;
  parameters["agents"] = options.scheduler.ai.agents;
  parameters["capture_every"] = options.capture_every;

  nlohmann::json errors = columnStatistics(run.rows, false);
  errors["escaped_final"] = run.rows.back().frame.physics.escaped;
  errors["sunk_final"] = run.rows.back().frame.physics.sunk;
  const double mean_substeps = errors["substeps"]["mean"];
  errors["substeps_x_boxes"] = mean_substeps * config.objects;  // a load-free cost proxy
  return {{"command", "run"},
          {"parameters", parameters},
          {"layout",
           {{"interior_half_extent", run.layout.half_extent},
            {"wall_thickness", run.layout.wall_thickness}}},
          {"timings_ms", columnStatistics(run.rows, true)},
          {"counts", errors},
          {"state_hash", hex(run.state_hash)},
          {"sound_checksum", hex(run.sound_checksum)},
          {"ai_checksum", hex(run.ai_checksum)},
          {"wall_seconds", run.seconds},
          {"machine", machineInfo()}};
}

void run(const RunOptions& options) {
  const physics::SceneConfig config = options.scene.resolve();
  options.physics.resolve(options.algorithm, config);  // a bad choice fails before any output
  // Caps every oneTBB pool of the run: the tasks' and cpubf's alike.
  const std::optional<tbb::global_control> thread_cap = capThreads(options.threads);
  try {
    options.scheduler.sound.validate();
    options.scheduler.ai.validate();
  } catch (const std::invalid_argument& error) {
    throw UsageError(std::string("task options: ") + error.what());
  }
  prepareOutputDirectory(options.out, "--out");
  if (options.scheduler.wav) {
    const std::filesystem::path wav = *options.scheduler.wav;
    prepareOutputDirectory(wav.has_parent_path() ? wav.parent_path() : ".", "--wav");
  }
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

  std::optional<RunResult> sync_run;
  if (options.compare_sync) {
    SchedulerOptions sync_options = options.scheduler;
    sync_options.sync = true;
    sync_options.wav.reset();
    Timeline unused;
    sync_run = runOnce(options, config, sync_options, nullptr, unused, "overlap run (sync)");
  }
  Timeline timeline;
  const RunResult result =
      runOnce(options, config, options.scheduler, camera.get(), timeline, "overlap run");

  nlohmann::json summary = summarize(options, config, result);
  if (sync_run) {
    std::vector<double> sync_totals, async_totals;
    for (const FrameRow& row : sync_run->rows)
      sync_totals.push_back(row.frame.physics.timings.total_ms);
    for (const FrameRow& row : result.rows)
      async_totals.push_back(row.frame.physics.timings.total_ms);
    summary["compare_sync"] = {
        {"sync_total_ms_median", median(sync_totals)},
        {"async_total_ms_median", median(async_totals)},
        {"speedup", median(sync_totals) / median(async_totals)},
        {"sync_state_hash", hex(sync_run->state_hash)},
        {"identical_state", sync_run->state_hash == result.state_hash},
        {"identical_tasks", sync_run->sound_checksum == result.sound_checksum &&
                                sync_run->ai_checksum == result.ai_checksum}};
  }
  physics::writeFileAtomically(options.out / "frames.csv", framesCsv(result.rows));
  timeline.write(options.out / "timeline.json");
  physics::writeFileAtomically(options.out / "summary.json", summary.dump(2) + "\n");
}

}  // namespace

void addRunCommand(CLI::App& app) {
  auto options = std::make_shared<RunOptions>();
  CLI::App* command =
      app.add_subcommand("run", "step a scene; write frames.csv, summary.json and timeline.json");
  options->scene.addTo(*command);
  addAlgorithmOption(*command, options->algorithm);
  command->add_option("--frames", options->frames, "frames of 1/30 s")
      ->check(CLI::Range(1, 1'000'000))
      ->capture_default_str();
  options->physics.addTo(*command);
  command->add_flag("--sync", options->scheduler.sync,
                    "run the sound and AI tasks before the broadphase, not beside it");
  command
      ->add_option("--threads", options->threads,
                   "worker threads for the tasks and cpubf (0: all hardware threads)")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  command->add_flag("--compare-sync", options->compare_sync,
                    "run --sync first, then the async loop, and report the speed-up");
  command->add_flag("!--no-tasks", options->scheduler.tasks,
                    "physics only: no sound or AI tasks (the paper's measurements)");
  command->add_option("--voices", options->scheduler.sound.voices, "sound: voices mixed")
      ->capture_default_str();
  command
      ->add_option("--background-voices", options->scheduler.sound.background_voices,
                   "sound: of the voices, always sounding")
      ->capture_default_str();
  command->add_option("--agents", options->scheduler.ai.agents, "AI: steering agents")
      ->capture_default_str();
  command->add_option("--wav", options->scheduler.wav,
                      "write the run's sound mix to this WAV file");
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
