// `overlap run`: steps a scene through the frame scheduler and writes
// frames.csv, summary.json and timeline.json.
#include <oneapi/tbb/global_control.h>

#include <cstdio>
#include <cstdlib>
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
#include "engine/interrupt.h"
#include "engine/machine_info.h"
#include "engine/number_options.h"
#include "engine/physics_options.h"
#include "engine/progress.h"
#include "engine/scene_options.h"
#include "engine/statistics.h"
#include "engine/task_load.h"
#include "gpu/base/output_file.h"
#include "gpu/base/stopwatch.h"
#include "physics/default_broadphase.h"
#include "physics/world.h"

namespace overlap::engine {
namespace {

// `overlap run` with no options is the demo: scene 4 at a size that finishes
// within a minute on two cores without a GPU (README.md has the time
// measured), with every output written.
// --paper is the paper's full run (docs/SCENES.md: 3500 boxes, 2048 frames).
constexpr int kDemoObjects = 1000;
constexpr int kDemoFrames = 300;
constexpr int kPaperObjects = 3500;
constexpr int kPaperFrames = 2048;
// PNGs the demo writes when --capture-every is not given: frames 0, F/4, F/2, 3F/4.
constexpr int kDefaultKeyframes = 4;

struct RunOptions {
  SceneOptions scene;
  std::string algorithm;
  const CLI::Option* algo_option = nullptr;
  std::string default_algorithm_reason;  // set when --algo was not given
  int frames = kDemoFrames;
  bool paper = false;
  PhysicsOptions physics;
  bool compare_sync = false;
  int threads = 0;  // 0: every hardware thread
  std::optional<double> task_load;
  SchedulerOptions scheduler;
  std::filesystem::path out = "out";
  std::optional<int> capture_every;  // unset: kDefaultKeyframes pictures; 0: none
  std::string capture_size = "800x600";
  std::optional<std::filesystem::path> wav;  // unset: OUT/sound.wav
  bool no_wav = false;
  bool no_tasks = false;
  std::optional<std::filesystem::path> wav_file;  // resolved: the WAV the run writes, if any
  // For the checks between options (refuseConflicts).
  CLI::Option* frames_option = nullptr;
  CLI::Option* paper_option = nullptr;
  CLI::Option* sync_option = nullptr;
  CLI::Option* compare_sync_option = nullptr;
  CLI::Option* no_tasks_option = nullptr;
  CLI::Option* wav_option = nullptr;
  CLI::Option* no_wav_option = nullptr;
  CLI::Option* task_options[3] = {};  // --voices, --background-voices, --agents
  CLI::Option* capture_every_option = nullptr;
  CLI::Option* capture_size_option = nullptr;
};

// The documented bounds of the task sizes (docs/CLI.md): a voice or an agent
// costs a few hundred bytes and its share of every frame.
constexpr int kMostVoices = 100'000;
constexpr int kMostAgents = 100'000;

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
      {"ccd_query_ms", [](R r) { return r.frame.physics.timings.ccd_query_ms; }, true},
      {"physics_ms", [](R r) { return r.frame.physics.timings.total_ms; }, true},
      {"total_ms", [](R r) { return toMilliseconds(r.frame.whole.length()); }, true},
      {"sound_ms", [](R r) { return toMilliseconds(r.frame.taskTime(kSoundTask)); }, true},
      {"ai_ms", [](R r) { return toMilliseconds(r.frame.taskTime(kAiTask)); }, true},
      {"tasks_wait_ms", [](R r) { return toMilliseconds(r.frame.waitTime()); }, true},
      {"tasks_hidden", [](R r) { return r.frame.tasks_hidden; }, true},
      {"search_ms", [](R r) { return r.frame.physics.timings.search_ms; }, true},
      {"join_ms", [](R r) { return r.frame.physics.timings.join_ms; }, true},
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

physics::WorldOptions worldOptions(const RunOptions& options, const physics::SceneConfig& config) {
  return options.physics.resolve(options.algorithm, config);
}

// A run in progress: one world and its scheduler, stepped a frame at a time.
// --compare-sync steps a sync and an async run in turn, frame by frame, so a
// change in the machine's load or clock during the run reaches both alike.
class SteppedRun {
 public:
  SteppedRun(const RunOptions& options, const physics::SceneConfig& config,
             const SchedulerOptions& scheduler_options, Timeline& timeline)
      : world_(makeWorld(config, worldOptions(options, config))),
        scheduler_(*world_, scheduler_options, timeline) {}

  const physics::PhysicsWorld& world() const { return *world_; }

  FrameRow& step() {
    rows_.push_back(FrameRow{scheduler_.runFrame()});
    return rows_.back();
  }

  RunResult finish(double seconds) {
    scheduler_.close();
    return {std::move(rows_),        world_->algorithm(),
            world_->stateHash(),     scheduler_.soundChecksum(),
            scheduler_.aiChecksum(), seconds,
            world_->layout()};
  }

 private:
  std::unique_ptr<physics::PhysicsWorld> world_;
  FrameScheduler scheduler_;
  std::vector<FrameRow> rows_;
};

nlohmann::json summarize(const RunOptions& options, const physics::SceneConfig& config,
                         const RunResult& run,
                         const std::optional<TaskLoadCalibration>& calibration) {
  nlohmann::json parameters = toJson(config);
  parameters["algorithm_requested"] = options.algorithm;
  parameters["algorithm"] = run.algorithm;
  parameters["frames"] = options.frames;
  parameters.update(toJson(options.physics.resolve(options.algorithm, config)));
  parameters["sync"] = options.scheduler.sync;
  parameters["threads"] = options.threads;
  parameters["tasks"] = options.scheduler.tasks;
  parameters["voices"] = options.scheduler.sound.voices;
  parameters["background_voices"] = options.scheduler.sound.background_voices;
  parameters["agents"] = options.scheduler.ai.agents;
  if (options.task_load) parameters["task_load"] = *options.task_load;
  if (calibration) parameters["task_load_calibration"] = toJson(*calibration);
  parameters["capture_every"] = *options.capture_every;

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

// What --paper, --capture-every and --wav leave unsaid, filled in.
RunOptions resolveDefaults(RunOptions options, physics::SceneConfig& config) {
  if (options.paper) {
    if (!options.scene.objectsGiven()) config.objects = kPaperObjects;
    if (options.frames_option->count() == 0) options.frames = kPaperFrames;
  }
  if (!options.capture_every) {
    options.capture_every =
        std::max(1, (options.frames + kDefaultKeyframes - 1) / kDefaultKeyframes);
  }
  if (options.algo_option != nullptr && options.algo_option->count() == 0) {
    physics::DefaultBroadphase pick =
        physics::defaultBroadphaseHere(static_cast<std::size_t>(config.objects));
    options.algorithm = std::string(pick.name);
    options.default_algorithm_reason = std::move(pick.reason);
  }
  options.scheduler.tasks = !options.no_tasks;
  if (!options.no_wav && !options.no_tasks) {
    options.wav_file = options.wav.value_or(options.out / "sound.wav");
  }
  return options;
}

// Options that conflict, or that the run would ignore, refused once parsing
// is done and before any work, naming both.
void refuseConflicts(const RunOptions& options) {
  refuseTogether(options.wav_option, options.no_wav_option, "--no-wav writes no WAV");
  refuseTogether(options.sync_option, options.compare_sync_option,
                 "--compare-sync runs a --sync run beside the async one itself");
  for (const CLI::Option* ignored : {options.wav_option, options.task_options[0],
                                     options.task_options[1], options.task_options[2]}) {
    refuseTogether(ignored, options.no_tasks_option,
                   "--no-tasks runs no sound and no AI, so the first would be ignored");
  }
  if (options.capture_every && *options.capture_every == 0) {
    refuseTogether(options.capture_size_option, options.capture_every_option,
                   "--capture-every 0 writes no PNG, so --capture-size would be ignored");
  }
  if (options.paper && options.scene.objectsGiven() && options.frames_option->count() > 0) {
    throw UsageError(
        "--paper with --objects and --frames: both of its numbers are given, so --paper would "
        "be ignored");
  }
  const stubs::SoundConfig& sound = options.scheduler.sound;
  if (sound.background_voices > sound.voices) {
    throw UsageError("--background-voices " + std::to_string(sound.background_voices) +
                     (options.task_options[1]->count() > 0 ? "" : " (its default)") +
                     " must be at most --voices " + std::to_string(sound.voices));
  }
}

// Every output the run will write, checked before any work: a name that is
// a folder, or a folder that cannot be written, is a UsageError.
void checkOutputs(const RunOptions& options, const physics::SceneConfig& config) {
  prepareOutputDirectory(options.out, "--out");
  for (const char* name : {"frames.csv", "summary.json", "timeline.json"}) {
    prepareOutputFile(options.out / name, "--out");
  }
  if (options.wav_file) prepareOutputFile(*options.wav_file, options.wav ? "--wav" : "--out");
  if (*options.capture_every > 0) {
    prepareOutputDirectory(options.out / "frames", "--out");
    for (int frame = 0; frame < options.frames; frame += *options.capture_every) {
      prepareOutputFile(options.out / "frames" / pngName(config.scene, frame), "--out");
    }
  }
}

// The closing line: every file the run wrote, where.
std::string writtenLine(const std::filesystem::path& out,
                        const std::optional<std::filesystem::path>& wav,
                        const FrameCapture* camera) {
  std::string line = "overlap run: wrote " + (out / "frames.csv").string() + ", " +
                     (out / "summary.json").string() + ", " + (out / "timeline.json").string() +
                     " (open in https://ui.perfetto.dev)";
  if (wav) line += ", " + wav->string();
  if (camera != nullptr && !camera->written().empty()) {
    line += ", " + std::to_string(camera->written().size()) + " PNGs in " +
            camera->written().front().parent_path().string() + " (" +
            camera->written().front().filename().string() + " to " +
            camera->written().back().filename().string() + ")";
  }
  return line;
}

void run(const RunOptions& given) {
  physics::SceneConfig config = given.scene.resolve();
  RunOptions options = resolveDefaults(given, config);
  options.physics.resolve(options.algorithm, config);  // a bad choice fails before any output
  // Caps every oneTBB pool of the run: the tasks' and cpubf's alike.
  const std::optional<tbb::global_control> thread_cap = capThreads(options.threads);
  try {
    options.scheduler.sound.validate();
    options.scheduler.ai.validate();
  } catch (const std::invalid_argument& error) {
    throw UsageError(std::string("task options: ") + error.what());
  }
  checkOutputs(options, config);
  // Everything goes to temporaries, published together at the end.
  OutputFolder outputs(options.out);
  if (options.wav_file) options.scheduler.wav = &outputs.open(*options.wav_file);
  std::optional<TaskLoadCalibration> calibration;
  if (options.task_load && options.scheduler.tasks) {
    calibration =
        calibrateTaskLoad(*options.task_load, options.frames, config, worldOptions(options, config),
                          options.scheduler.sound, options.scheduler.ai);
    std::fprintf(stderr,
                 "overlap: task load %g: physics step %.3g ms (median of %d physics-only "
                 "frames) -> %d voices (%d always sounding), %d agents\n",
                 *options.task_load, calibration->physics_ms, calibration->physics_frames,
                 calibration->voices, calibration->background_voices, calibration->agents);
  }
  std::unique_ptr<FrameCapture> camera;
  if (*options.capture_every > 0) {
    // --threads bounds the renderer too: OSMesa's llvmpipe draws on the
    // calling thread and keeps no shader-cache thread (unless the user's
    // environment says otherwise).
    setenv("LP_NUM_THREADS", "0", 0);
    setenv("MESA_SHADER_CACHE_DISABLE", "true", 0);
    camera = openCapture(outputs, options.out / "frames", options.capture_size,
                         render::ColourMode::kSizeClass);
  }

  std::optional<SteppedRun> sync_stepper;
  Timeline sync_timeline;  // not written: timeline.json is the async run's
  if (options.compare_sync) {
    SchedulerOptions sync_options = options.scheduler;
    sync_options.sync = true;
    sync_options.wav = nullptr;
    sync_stepper.emplace(options, config, sync_options, sync_timeline);
  }
  Timeline timeline;
  SteppedRun stepper(options, config, options.scheduler, timeline);
  // Once the scene is built: a scene that cannot be placed says only that.
  if (!options.default_algorithm_reason.empty()) {
    std::fprintf(stderr, "overlap: %s\n", options.default_algorithm_reason.c_str());
  }
  Progress progress(options.compare_sync ? "overlap run (sync and async)" : "overlap run",
                    options.frames);
  for (int frame = 0; frame < options.frames; ++frame) {
    stopIfInterrupted("frame " + std::to_string(frame) + " of " + std::to_string(options.frames));
    if (sync_stepper) sync_stepper->step();
    FrameRow& row = stepper.step();
    if (camera != nullptr && frame % *options.capture_every == 0) {
      row.render_ms = camera->capture(stepper.world(), frame);
    }
    progress.update(frame + 1);
  }
  progress.finish();
  std::optional<RunResult> sync_run;
  if (sync_stepper) sync_run = sync_stepper->finish(progress.seconds());
  const RunResult result = stepper.finish(progress.seconds());

  nlohmann::json summary = summarize(options, config, result, calibration);
  if (sync_run) {
    const auto medianOf = [](const std::vector<FrameRow>& rows, auto value) {
      std::vector<double> values;
      for (const FrameRow& row : rows) values.push_back(value(row.frame));
      return median(values);
    };
    const auto frameMs = [](const ScheduledFrame& f) { return toMilliseconds(f.whole.length()); };
    const auto physicsMs = [](const ScheduledFrame& f) { return f.physics.timings.total_ms; };
    const auto tasksMs = [](const ScheduledFrame& f) {
      return toMilliseconds(f.taskTime(kSoundTask) + f.taskTime(kAiTask));
    };
    const double sync_ms = medianOf(sync_run->rows, frameMs);
    const double async_ms = medianOf(result.rows, frameMs);
    summary["compare_sync"] = {
        {"sync_total_ms_median", sync_ms},
        {"async_total_ms_median", async_ms},
        {"speedup", sync_ms / async_ms},
        // The sync run's parts: what the async frame overlaps.
        {"sync_physics_ms_median", medianOf(sync_run->rows, physicsMs)},
        {"sync_tasks_ms_median", medianOf(sync_run->rows, tasksMs)},
        {"async_physics_ms_median", medianOf(result.rows, physicsMs)},
        {"async_tasks_ms_median", medianOf(result.rows, tasksMs)},
        {"sync_state_hash", hex(sync_run->state_hash)},
        {"identical_state", sync_run->state_hash == result.state_hash},
        {"identical_tasks", sync_run->sound_checksum == result.sound_checksum &&
                                sync_run->ai_checksum == result.ai_checksum}};
  }
  outputs.open(options.out / "frames.csv").write(framesCsv(result.rows));
  outputs.open(options.out / "timeline.json").write(timeline.json());
  outputs.open(options.out / "summary.json").write(summary.dump(2) + "\n");
  outputs.commit();
  std::fprintf(stderr, "%s\n", writtenLine(options.out, options.wav_file, camera.get()).c_str());
}

// A flag that is off unless given.
CLI::Option* addFlag(CLI::App& command, const std::string& name, bool& value,
                     const std::string& description) {
  return command.add_flag(name, value, description)->default_str("off");
}

}  // namespace

void addRunCommand(CLI::App& app) {
  auto options = std::make_shared<RunOptions>();
  CLI::App* command = app.add_subcommand(
      "run",
      "step a scene through the frame scheduler; write frames.csv, summary.json, "
      "timeline.json, the sound as a WAV and keyframe PNGs.  With no options: the demo, scene 4 "
      "with " +
          std::to_string(kDemoObjects) + " boxes for " + std::to_string(kDemoFrames) +
          " frames (its time on two cores: see README.md); --paper for the paper's full run");
  options->scene.addTo(*command, kDemoObjects);
  addAlgorithmOption(*command, options->algorithm);
  options->algo_option = command->get_option("--algo");
  options->frames_option =
      command->add_option("--frames", options->frames, "frames to run, each --frame-time long")
          ->check(wholeNumberIn(1, kMostFrames))
          ->capture_default_str();
  options->paper_option =
      addFlag(*command, "--paper", options->paper,
              "the paper's full run: --objects " + std::to_string(kPaperObjects) + " --frames " +
                  std::to_string(kPaperFrames) +
                  " (about half an hour on two cores without a GPU); either given "
                  "explicitly wins");
  options->physics.addTo(*command);
  options->sync_option =
      addFlag(*command, "--sync", options->scheduler.sync,
              "run the frame's jobs one after another: the sound and AI tasks, then the "
              "physics step (default: the tasks beside the whole step)");
  addThreadsOption(*command, options->threads);
  options->compare_sync_option =
      addFlag(*command, "--compare-sync", options->compare_sync,
              "step a --sync run and the async run in turn, frame by frame, in one process, "
              "and report the speed-up");
  CLI::Option* task_load =
      command
          ->add_option("--task-load", options->task_load,
                       "size the sound and AI tasks to cost X times the physics step, measured "
                       "on the scene's first frames (instead of --voices, --background-voices, "
                       "--agents)")
          ->check(realNumberIn(0.0, 100.0))
          ->default_str("unset: --voices and --agents");
  CLI::Option* no_tasks = addFlag(*command, "--no-tasks", options->no_tasks,
                                  "physics only: no sound or AI tasks (the paper's measurements)");
  CLI::Option* voices =
      command->add_option("--voices", options->scheduler.sound.voices, "sound: voices mixed")
          ->check(wholeNumberIn(0, kMostVoices))
          ->capture_default_str();
  CLI::Option* background_voices =
      command
          ->add_option("--background-voices", options->scheduler.sound.background_voices,
                       "sound: of the voices, always sounding (at most --voices)")
          ->check(wholeNumberIn(0, kMostVoices))
          ->capture_default_str();
  CLI::Option* agents =
      command->add_option("--agents", options->scheduler.ai.agents, "AI: steering agents")
          ->check(wholeNumberIn(0, kMostAgents))
          ->capture_default_str();
  // The knob sizes the tasks itself: with the tasks off, or sized by hand, it is a mistake.
  for (CLI::Option* other : {no_tasks, voices, background_voices, agents}) {
    task_load->excludes(other);
  }
  options->no_tasks_option = no_tasks;
  options->task_options[0] = voices;
  options->task_options[1] = background_voices;
  options->task_options[2] = agents;
  options->wav_option =
      command
          ->add_option("--wav", options->wav,
                       "the WAV file the run's sound mix goes to (a FIFO or device is written "
                       "through)")
          ->default_str("OUT/sound.wav");
  options->no_wav_option = addFlag(*command, "--no-wav", options->no_wav, "write no WAV");
  command
      ->add_option("--out", options->out,
                   "output folder; a run replaces the outputs of the last run there, and only "
                   "those")
      ->capture_default_str();
  options->capture_every_option =
      command
          ->add_option("--capture-every", options->capture_every,
                       "write every K-th frame as a PNG under OUT/frames (0: none)")
          ->check(wholeNumberIn(0, kMostFrames))
          ->default_str("a quarter of --frames: " + std::to_string(kDefaultKeyframes) + " PNGs");
  options->capture_size_option =
      command->add_option("--capture-size", options->capture_size, "PNG size WIDTHxHEIGHT")
          ->capture_default_str();
  command->footer(
      "Examples:\n"
      "  overlap run                                  # the demo, into ./out\n"
      "  overlap run --paper --algo bvh --out paper   # the paper's scene 4 with Bullet's BVH\n"
      "  overlap run --scene 2 --objects 1000 --frames 300 --no-tasks --out s2");
  command->parse_complete_callback([options] { refuseConflicts(*options); });
  command->callback([options] { run(*options); });
}

}  // namespace overlap::engine
