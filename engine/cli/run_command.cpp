// `overlap run`: steps a scene through the frame scheduler, writes
// frames.csv, summary.json and timeline.json, and ends with its summary.
//
// Three stages, each reading only what the one before produced:
//   resolve  the parsed arguments become a RunPlan: every default filled in,
//            the world's options and the tasks' sizes checked once, so a bad
//            choice fails before any output;
//   step     the plan's world(s) stepped frame by frame into RunResults;
//   write    the results and the plan into the output folder, published
//            together; then the summary on stderr (engine/runtime/run_summary.h).

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <iomanip>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <thread>
#include <vector>

#include "engine/cli/commands.h"
#include "engine/cli/frame_capture.h"
#include "engine/cli/physics_options.h"
#include "engine/cli/world_setup.h"
#include "engine/program/machine_info.h"
#include "engine/program/number_options.h"
#include "engine/program/option_conflicts.h"
#include "engine/program/output_checks.h"
#include "engine/program/program_runner.h"
#include "engine/program/progress.h"
#include "engine/program/scene_options.h"
#include "engine/program/summary_output.h"
#include "engine/program/wording.h"
#include "engine/runtime/frame_scheduler.h"
#include "engine/runtime/game_session.h"
#include "engine/runtime/run_summary.h"
#include "engine/runtime/sound_and_ai.h"
#include "engine/runtime/statistics.h"
#include "engine/runtime/task_load.h"
#include "gpu/base/interrupt.h"
#include "gpu/base/output_file.h"
#include "gpu/base/stopwatch.h"
#include "physics/world.h"

namespace overlap::engine {
namespace {

// `overlap run` with no options is the demo: scene 4 at a size that finishes
// within a minute on two cores without a GPU (docs/results/run_costs.md has
// the time measured), with every output written.
// --paper is the paper's full run (docs/SCENES.md: 3500 boxes, 2048 frames).
constexpr int kDemoObjects = 1000;
constexpr int kDemoFrames = 300;
constexpr int kPaperObjects = 3500;
constexpr int kPaperFrames = 2048;
// PNGs the demo writes when --capture-every is not given: frames 0, F/4, F/2, 3F/4.
constexpr int kDefaultKeyframes = 4;

// The command line's values as parsed: nothing filled in or checked between options.
struct RunArguments {
  SceneOptions scene;
  std::optional<std::string> algorithm;  // unset: the box-count rule
  int frames = kDemoFrames;
  bool paper = false;
  PhysicsOptions physics;
  bool sync = false;
  bool compare_sync = false;
  int threads = 0;  // 0: every hardware thread
  std::optional<double> task_load;
  stubs::SoundConfig sound;
  stubs::AiConfig ai;
  std::filesystem::path out = "out";
  std::optional<int> capture_every;  // unset: kDefaultKeyframes pictures; 0: none
  std::string capture_size = "800x600";
  std::optional<std::filesystem::path> wav;  // unset: OUT/sound.wav
  bool no_wav = false;
  bool no_tasks = false;
  bool quiet = false;
};

// The options as CLI11 made them, for the checks between options.
struct RunOptionHandles {
  CLI::Option* frames = nullptr;
  CLI::Option* sync = nullptr;
  CLI::Option* compare_sync = nullptr;
  CLI::Option* no_tasks = nullptr;
  CLI::Option* wav = nullptr;
  CLI::Option* no_wav = nullptr;
  CLI::Option* voices = nullptr;
  CLI::Option* background_voices = nullptr;
  CLI::Option* agents = nullptr;
  CLI::Option* capture_every = nullptr;
  CLI::Option* capture_size = nullptr;
};

// What the run does, every default filled in and checked: the stages after
// resolvePlan() read only this.
struct RunPlan {
  physics::SceneConfig config;
  std::optional<std::string> algorithm_requested;  // unset: --algo not given
  std::string default_algorithm_reason;            // why, when --algo was not given
  physics::WorldOptions world;
  int frames = 0;
  bool sync = false;
  bool compare_sync = false;
  int threads = 0;
  bool tasks = true;  // false: physics only (the paper's measurements)
  stubs::SoundConfig sound;
  stubs::AiConfig ai;
  std::optional<double> task_load;
  std::optional<TaskLoadCalibration> calibration;  // set by calibrateTasks()
  std::filesystem::path out;
  int capture_every = 0;           // 0: no PNGs
  bool quarter_keyframes = false;  // --capture-every not given: frames 0, F/4, F/2, 3F/4
  std::string capture_size;
  std::optional<std::filesystem::path> wav_file;  // the WAV the run writes, if any
  const char* wav_option = "--out";               // the option that named it
  bool quiet = false;                             // no summary at the end
};

struct FrameRow {
  ScheduledFrame frame;
  double render_ms = 0;
};

// frames.csv's numeric columns, each with how to read it from a row.
struct Column {
  const char* name;
  std::function<double(const FrameRow&)> value;
  bool timing;  // summarised with mean, median, p95, p99 and max in summary.json
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
      {"search_hidden_ms", [](R r) { return r.frame.physics.timings.search_hidden_ms; }, true},
      {"physics_ms", [](R r) { return r.frame.physics.timings.total_ms; }, true},
      {"total_ms", [](R r) { return toMilliseconds(r.frame.whole.length()); }, true},
      {"cpu_ms", [](R r) { return r.frame.cpu_ms; }, true},
      {"sound_ms", [](R r) { return toMilliseconds(r.frame.taskTime(kSoundTask)); }, true},
      {"ai_ms", [](R r) { return toMilliseconds(r.frame.taskTime(kAiTask)); }, true},
      {"tasks_wait_ms", [](R r) { return toMilliseconds(r.frame.waitTime()); }, true},
      {"tasks_hidden", [](R r) { return r.frame.tasks_hidden; }, true},
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
    const FrameSpread spread = spreadOf(values);
    statistics[column.name] = {
        {"mean", mean(values)}, {"median", spread.median}, {"max", spread.max}};
    if (timing) {
      statistics[column.name]["p95"] = spread.p95;
      statistics[column.name]["p99"] = spread.p99;
    }
  }
  return statistics;
}

std::string hex(std::uint64_t value) {
  std::ostringstream text;
  text << std::hex << std::setw(16) << std::setfill('0') << value;
  return text.str();
}

// ---- resolve ----

// Options that conflict, or that the run would ignore, refused once parsing
// is done and before any work, naming both.
void refuseConflicts(const RunArguments& arguments, const RunOptionHandles& given) {
  refuseTogether(given.wav, given.no_wav, "--no-wav writes no WAV");
  refuseTogether(given.sync, given.compare_sync,
                 "--compare-sync runs a --sync run beside the async one itself");
  for (const CLI::Option* ignored :
       {given.wav, given.voices, given.background_voices, given.agents}) {
    refuseTogether(ignored, given.no_tasks,
                   "--no-tasks runs no sound and no AI, so the first would be ignored");
  }
  if (arguments.capture_every && *arguments.capture_every == 0) {
    refuseTogether(given.capture_size, given.capture_every,
                   "--capture-every 0 writes no PNG, so --capture-size would be ignored");
  }
  if (arguments.paper && arguments.scene.objectsGiven() && given.frames->count() > 0) {
    throw UsageError(
        "--paper with --objects and --frames: both of its numbers are given, so --paper would "
        "be ignored");
  }
  const stubs::SoundConfig& sound = arguments.sound;
  if (sound.background_voices > sound.voices) {
    throw UsageError("--background-voices " + std::to_string(sound.background_voices) +
                     (given.background_voices->count() > 0 ? "" : " (its default)") +
                     " must be at most --voices " + std::to_string(sound.voices));
  }
}

// The arguments with what --paper, --capture-every and --wav leave unsaid
// filled in, and every choice checked: a bad one is a UsageError.
RunPlan resolvePlan(const RunArguments& arguments, const RunOptionHandles& given) {
  RunPlan plan;
  plan.config = arguments.scene.resolve();
  plan.frames = arguments.frames;
  if (arguments.paper) {
    if (!arguments.scene.objectsGiven()) plan.config.objects = kPaperObjects;
    if (given.frames->count() == 0) plan.frames = kPaperFrames;
  }
  plan.algorithm_requested = arguments.algorithm;
  ChosenAlgorithm algorithm = chooseAlgorithm(arguments.algorithm, plan.config.objects);
  plan.default_algorithm_reason = std::move(algorithm.default_reason);
  plan.world = arguments.physics.resolve(algorithm.name, plan.config);
  plan.sync = arguments.sync;
  plan.compare_sync = arguments.compare_sync;
  plan.threads = arguments.threads;
  plan.tasks = !arguments.no_tasks;
  plan.sound = arguments.sound;
  plan.ai = arguments.ai;
  // The tasks' frame is the scene's: checked here, not when the first frame runs.
  plan.sound.frame_seconds = plan.ai.frame_seconds = plan.config.frame_time;
  if (plan.tasks && plan.sound.samplesPerFrame() < 1) {
    std::ostringstream frame_time;
    frame_time << plan.config.frame_time;
    throw UsageError("--frame-time " + frame_time.str() + " is shorter than one sample of the " +
                     "sound task (1/" + std::to_string(plan.sound.sample_rate) +
                     " s); lengthen it or give --no-tasks");
  }
  if (plan.tasks) {
    try {
      plan.sound.validate();
      plan.ai.validate();
    } catch (const std::invalid_argument& error) {
      throw UsageError(std::string("task options: ") + error.what());
    }
  }
  plan.task_load = arguments.task_load;
  plan.out = arguments.out;
  plan.quarter_keyframes = !arguments.capture_every.has_value();
  plan.capture_every =
      arguments.capture_every.value_or(std::max(1, plan.frames / kDefaultKeyframes));
  plan.capture_size = arguments.capture_size;
  if (!arguments.no_wav && plan.tasks) {
    plan.wav_file = arguments.wav.value_or(plan.out / "sound.wav");
    plan.wav_option = arguments.wav ? "--wav" : "--out";
  }
  plan.quiet = arguments.quiet;
  return plan;
}

// Whether the run writes `frame` as a PNG: every --capture-every-th, or by
// default frames 0, F/4, F/2 and 3F/4 (fewer when F < 4).
bool isKeyframe(const RunPlan& plan, int frame) {
  if (plan.capture_every == 0) return false;
  if (!plan.quarter_keyframes) return frame % plan.capture_every == 0;
  for (long long quarter = 0; quarter < kDefaultKeyframes; ++quarter) {
    if (frame == quarter * plan.frames / kDefaultKeyframes) return true;
  }
  return false;
}

// Every output the run will write, declared before any work: a name that is
// a folder, a folder that cannot be written, or two outputs that are one
// file is a UsageError.
void declareOutputs(OutputFolder& outputs, const RunPlan& plan) {
  prepareOutputDirectory(plan.out, "--out");
  for (const char* name : {"frames.csv", "summary.json", "timeline.json"}) {
    declareOutput(outputs, plan.out / name, "--out");
  }
  if (plan.capture_every > 0) {
    for (int frame = 0; frame < plan.frames; ++frame) {
      if (!isKeyframe(plan, frame)) continue;
      declareOutput(outputs, plan.out / "frames" / pngName(plan.config.scene, frame), "--out");
    }
  }
  if (plan.wav_file) declareOutput(outputs, *plan.wav_file, plan.wav_option);
}

// --task-load: the tasks sized against the scene's physics step, measured now.
void calibrateTasks(RunPlan& plan) {
  if (!plan.task_load || !plan.tasks) return;
  std::ostringstream load;
  load << *plan.task_load;
  Progress calibrating("overlap: calibrating --task-load " + load.str(), 0);
  plan.calibration =
      calibrateTaskLoad(*plan.task_load, plan.frames, plan.config, plan.world, plan.sound, plan.ai);
  calibrating.finish();
  const TaskLoadCalibration& calibration = *plan.calibration;
  if (!calibration.beyond_bound.empty()) {
    const bool sound = calibration.beyond_bound == "sound";
    throw UsageError(
        "--task-load " + load.str() + ": the " + calibration.beyond_bound + " task at its most (" +
        (sound ? std::to_string(kMostVoices) + " voices"
               : std::to_string(kMostAgents) + " agents") +
        ") costs " + fixedText(sound ? calibration.sound_ms : calibration.ai_ms, 3) +
        " ms, less than its share of " + load.str() + " x the " +
        fixedText(calibration.physics_ms, 3) + " ms physics step; give a lower --task-load");
  }
  std::fprintf(stderr,
               "overlap: task load %g: physics step %.3g ms (median of %d physics-only "
               "frames) -> %d voices (%d always sounding), %d agents\n",
               *plan.task_load, calibration.physics_ms, calibration.physics_frames,
               calibration.voices, calibration.background_voices, calibration.agents);
}

// ---- step ----

struct RunResult {
  std::vector<FrameRow> rows;
  std::string algorithm;
  std::uint64_t state_hash = 0;
  std::uint64_t sound_checksum = 0;
  std::uint64_t ai_checksum = 0;
  double seconds = 0;
  physics::SceneLayout layout;
};

// A run in progress: its game session (engine/runtime/game_session.h) and
// the frames.csv rows it keeps.  --compare-sync steps a sync and an async
// run in turn, frame by frame, so a change in the machine's load or clock
// during the run reaches both alike.
class SteppedRun {
 public:
  SteppedRun(const RunPlan& plan, bool sync, OutputFile* wav)
      : session_(makeWorld(plan.config, plan.world), sessionOptions(plan, sync, wav)) {}

  GameSession& session() { return session_; }

  FrameRow& keep(const ScheduledFrame& frame) {
    rows_.push_back(FrameRow{frame});
    return rows_.back();
  }

  RunResult finish(double seconds) {
    session_.finish();
    const physics::PhysicsWorld& world = session_.world();
    return {std::move(rows_),      world.algorithm(), world.stateHash(), session_.soundChecksum(),
            session_.aiChecksum(), seconds,           world.layout()};
  }

 private:
  static GameSessionOptions sessionOptions(const RunPlan& plan, bool sync, OutputFile* wav) {
    GameSessionOptions options{sync, std::nullopt};
    if (plan.tasks) options.tasks = SoundAndAiOptions{plan.sound, plan.ai, wav};
    return options;
  }

  GameSession session_;
  std::vector<FrameRow> rows_;
};

std::unique_ptr<FrameCapture> openCamera(const RunPlan& plan, OutputFolder& outputs) {
  if (plan.capture_every == 0) return nullptr;
  // --threads bounds the renderer too: OSMesa's llvmpipe draws on the
  // calling thread and keeps no shader-cache thread (unless the user's
  // environment says otherwise).
  setenv("LP_NUM_THREADS", "0", 0);
  setenv("MESA_SHADER_CACHE_DISABLE", "true", 0);
  return openCapture(outputs, plan.out / "frames", plan.capture_size,
                     render::ColourMode::kSizeClass);
}

struct SteppedRuns {
  RunResult async_run;                // or the --sync run, with --sync
  std::optional<RunResult> sync_run;  // --compare-sync's
  double load_at_start = 0;           // the load average before the first frame
  Timeline timeline;                  // the async run's (timeline.json)
};

SteppedRuns stepRuns(const RunPlan& plan, OutputFile* wav, FrameCapture* camera) {
  std::optional<SteppedRun> sync_stepper;
  if (plan.compare_sync) sync_stepper.emplace(plan, true, nullptr);
  std::optional<SteppedRun> stepper;
  stepper.emplace(plan, plan.sync, wav);
  // Once the scene is built: a scene that cannot be placed says only that.
  if (!plan.default_algorithm_reason.empty()) {
    std::fprintf(stderr, "overlap: %s\n", plan.default_algorithm_reason.c_str());
  }
  const double load_at_start = loadAverage();
  Progress progress(plan.compare_sync ? "overlap run (sync and async)" : "overlap run",
                    plan.frames);
  GameSession& session = stepper->session();
  session.runFrames(
      plan.frames,
      [&](int frame, const ScheduledFrame& scheduled) {
        FrameRow& row = stepper->keep(scheduled);
        if (camera != nullptr && isKeyframe(plan, frame)) {
          row.render_ms = camera->capture(session.world(), frame);
        }
        progress.update(frame + 1);
      },
      [&](int) {
        if (sync_stepper) sync_stepper->keep(sync_stepper->session().step());
      });
  progress.finish();
  std::optional<RunResult> sync_run;
  if (sync_stepper) sync_run = sync_stepper->finish(progress.seconds());
  SteppedRuns runs{stepper->finish(progress.seconds()), std::move(sync_run), load_at_start,
                   session.timeline()};
  // Millions of boxes take seconds to release: said past a second, and a
  // signal meanwhile still stops the run before anything is published.
  Progress releasing("overlap: releasing " + std::to_string(plan.config.objects) + " boxes", 0);
  stepper.reset();
  sync_stepper.reset();
  releasing.finish();
  stopIfInterrupted("the release of the boxes after the last frame");
  return runs;
}

// ---- write ----

nlohmann::json parametersJson(const RunPlan& plan, const RunResult& run) {
  nlohmann::json parameters = toJson(plan.config);
  parameters["algorithm_requested"] =
      plan.algorithm_requested ? nlohmann::json(*plan.algorithm_requested) : nlohmann::json();
  parameters["algorithm"] = run.algorithm;
  parameters["frames"] = plan.frames;
  parameters.update(toJson(plan.world));
  parameters["sync"] = plan.sync;
  parameters["threads"] = threadsInUse();
  parameters["tasks"] = plan.tasks;
  parameters["voices"] = plan.sound.voices;
  parameters["background_voices"] = plan.sound.background_voices;
  parameters["agents"] = plan.ai.agents;
  if (plan.task_load) parameters["task_load"] = *plan.task_load;
  if (plan.calibration) parameters["task_load_calibration"] = toJson(*plan.calibration);
  parameters["capture_every"] = plan.capture_every;
  return parameters;
}

// The run's frames as its summary reads them: the whole frame and its step.
FrameSummary frameSummary(const RunPlan& plan, const RunResult& run) {
  FrameSummary frames(plan.config.frame_time);
  for (const FrameRow& row : run.rows) {
    frames.add(toMilliseconds(row.frame.whole.length()), row.frame.physics.timings);
  }
  return frames;
}

nlohmann::json summarize(const RunPlan& plan, const RunResult& run) {
  nlohmann::json errors = columnStatistics(run.rows, false);
  errors["escaped_final"] = run.rows.back().frame.physics.escaped;
  errors["sunk_final"] = run.rows.back().frame.physics.sunk;
  const double mean_substeps = errors["substeps"]["mean"];
  errors["substeps_x_boxes"] = mean_substeps * plan.config.objects;  // a load-free cost proxy
  return {{"command", "run"},
          {"parameters", parametersJson(plan, run)},
          {"layout",
           {{"interior_half_extent", run.layout.half_extent},
            {"wall_thickness", run.layout.wall_thickness}}},
          {"timings_ms", columnStatistics(run.rows, true)},
          {"frames_over_frame_time", frameSummary(plan, run).framesOverFrameTime()},
          {"counts", errors},
          {"state_hash", hex(run.state_hash)},
          {"sound_checksum", hex(run.sound_checksum)},
          {"ai_checksum", hex(run.ai_checksum)},
          {"wall_seconds", run.seconds},
          {"machine", machineInfo()}};
}

// The whole frames' milliseconds, in order.
std::vector<double> frameMs(const RunResult& run) {
  std::vector<double> values;
  for (const FrameRow& row : run.rows) values.push_back(toMilliseconds(row.frame.whole.length()));
  return values;
}

// --compare-sync's figures: the sync run against the async one.
nlohmann::json compareSyncJson(const RunResult& sync_run, const RunResult& async_run,
                               double load_at_start) {
  const auto medianOf = [](const std::vector<FrameRow>& rows, auto value) {
    std::vector<double> values;
    for (const FrameRow& row : rows) values.push_back(value(row.frame));
    return median(values);
  };
  const auto physicsMs = [](const ScheduledFrame& f) { return f.physics.timings.total_ms; };
  const auto tasksMs = [](const ScheduledFrame& f) {
    return toMilliseconds(f.taskTime(kSoundTask) + f.taskTime(kAiTask));
  };
  const Speedup speedup = speedupOf(frameMs(sync_run), frameMs(async_run));
  return {
      {"sync_total_ms_median", median(frameMs(sync_run))},
      {"async_total_ms_median", median(frameMs(async_run))},
      {"speedup", speedup.speedup},
      // Its spread over the frames, each stepped sync and async on the same state.
      {"speedup_frame_quartiles", {speedup.frames_q1, speedup.frames_median, speedup.frames_q3}},
      {"load_at_start", load_at_start},
      // The sync run's parts: what the async frame overlaps.
      {"sync_physics_ms_median", medianOf(sync_run.rows, physicsMs)},
      {"sync_tasks_ms_median", medianOf(sync_run.rows, tasksMs)},
      {"async_physics_ms_median", medianOf(async_run.rows, physicsMs)},
      {"async_tasks_ms_median", medianOf(async_run.rows, tasksMs)},
      {"sync_state_hash", hex(sync_run.state_hash)},
      {"identical_state", sync_run.state_hash == async_run.state_hash},
      {"identical_tasks", sync_run.sound_checksum == async_run.sound_checksum &&
                              sync_run.ai_checksum == async_run.ai_checksum}};
}

// The line before the summary: every file the run wrote, where, and the
// last run's files it removed.
std::string writtenLine(const std::filesystem::path& out,
                        const std::optional<std::filesystem::path>& wav, const FrameCapture* camera,
                        const std::vector<std::string>& removed) {
  std::string line = "overlap run: wrote " + (out / "frames.csv").string() + ", " +
                     (out / "summary.json").string() + ", " + (out / "timeline.json").string() +
                     " (open in https://ui.perfetto.dev)";
  if (wav) line += ", " + wav->string();
  if (camera != nullptr && !camera->written().empty()) {
    const std::vector<std::filesystem::path>& pngs = camera->written();
    line += ", " + counted(static_cast<long long>(pngs.size()), "PNG") + " in " +
            pngs.front().parent_path().string() + " (" + pngs.front().filename().string() +
            (pngs.size() > 1 ? " to " + pngs.back().filename().string() : "") + ")";
  }
  return line + removedText(removed);
}

// Returns the last run's files it removed (OutputFolder::commit).
std::vector<std::string> writeOutputs(const RunPlan& plan, const SteppedRuns& runs,
                                      OutputFolder& outputs) {
  nlohmann::json summary = summarize(plan, runs.async_run);
  if (runs.sync_run) {
    summary["compare_sync"] = compareSyncJson(*runs.sync_run, runs.async_run, runs.load_at_start);
  }
  outputs.open(plan.out / "frames.csv").write(framesCsv(runs.async_run.rows));
  outputs.open(plan.out / "timeline.json").write(runs.timeline.json());
  // A name may hold any bytes: one that is not UTF-8 is written as U+FFFD
  // (nlohmann's default throws, and only after the whole run).
  outputs.open(plan.out / "summary.json")
      .write(summary.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  return outputs.commit();
}

// The summary the run ends with (engine/runtime/run_summary.h): its frames,
// and with --compare-sync the speed-up, its spread and the load.
void printRunSummary(const RunPlan& plan, const SteppedRuns& runs) {
  const RunResult& run = runs.async_run;
  std::vector<std::string> lines = frameSummary(plan, run).lines();
  if (runs.sync_run) {
    const Speedup speedup = speedupOf(frameMs(*runs.sync_run), frameMs(run));
    lines.push_back("speed-up    " + fixedText(speedup.speedup, 2) +
                    ", the median sync frame over "
                    "the median async one; frame by frame " +
                    fixedText(speedup.frames_q1, 2) + " to " + fixedText(speedup.frames_q3, 2) +
                    " (quartiles of " + std::to_string(run.rows.size()) + "); load " +
                    fixedText(runs.load_at_start, 2) + " at the start, on " +
                    counted(std::thread::hardware_concurrency(), "hardware thread"));
  }
  const char* mode = plan.compare_sync ? "sync and async" : plan.sync ? "sync" : "async";
  printSummary(plan.quiet,
               "overlap run: " + counted(static_cast<long long>(run.rows.size()), "frame") +
                   " of scene " + std::to_string(plan.config.scene) + ", " +
                   std::to_string(plan.config.objects) + " boxes, " + run.algorithm + ", " + mode +
                   ", " + counted(threadsInUse(), "thread") + (plan.tasks ? "" : ", no tasks"),
               lines);
}

void run(const RunArguments& arguments, const RunOptionHandles& given) {
  RunPlan plan = resolvePlan(arguments, given);
  // Everything goes to temporaries, published together at the end.
  OutputFolder outputs(plan.out, "run");
  // A run's list never names a keyframe at the top: that is a capture's folder.
  outputs.takeOlderListsWhen([](const std::string& entry) { return !isKeyframeName(entry); });
  declareOutputs(outputs, plan);
  // The renderer's process is forked before this one starts a thread
  // (render/renderer_process.h); it opens no output.
  const std::unique_ptr<FrameCapture> camera = openCamera(plan, outputs);
  const RunThreads threads = runThreads(plan.threads);
  plan.world.tasks = threads.tasks.get();
  // Before any output is opened: a calibration stopped leaves no temporary.
  calibrateTasks(plan);
  OutputFile* wav = plan.wav_file ? &outputs.open(*plan.wav_file) : nullptr;
  const SteppedRuns runs = stepRuns(plan, wav, camera.get());
  const std::vector<std::string> removed = writeOutputs(plan, runs, outputs);
  std::fprintf(stderr, "%s\n",
               oneLine(writtenLine(plan.out, plan.wav_file, camera.get(), removed)).c_str());
  printRunSummary(plan, runs);
}

// ---- the command line ----

// A flag that is off unless given.
CLI::Option* addFlag(CLI::App& command, const std::string& name, bool& value,
                     const std::string& description) {
  return command.add_flag(name, value, description)->default_str("off");
}

// What the frame runs: --sync, --threads, --compare-sync.
void addFrameOptions(CLI::App& command, RunArguments& arguments, RunOptionHandles& given) {
  given.sync = addFlag(command, "--sync", arguments.sync,
                       "run the frame's jobs one after another: the sound and AI tasks, then the "
                       "physics step (default: the tasks beside the whole step)");
  addThreadsOption(command, arguments.threads);
  given.compare_sync =
      addFlag(command, "--compare-sync", arguments.compare_sync,
              "step a --sync run and the async run in turn, frame by frame, in one process, "
              "and report the speed-up");
}

// The sound and AI tasks: --task-load, --no-tasks, --voices, --background-voices, --agents.
void addTaskOptions(CLI::App& command, RunArguments& arguments, RunOptionHandles& given) {
  CLI::Option* task_load =
      command
          .add_option("--task-load", arguments.task_load,
                      "size the sound and AI tasks to cost X times the physics step, measured "
                      "on the scene's first frames (instead of --voices, --background-voices, "
                      "--agents)")
          ->check(realNumberIn(0.0, 100.0))
          ->default_str("unset: --voices and --agents");
  given.no_tasks = addFlag(command, "--no-tasks", arguments.no_tasks,
                           "physics only: no sound or AI tasks (the paper's measurements)");
  given.voices = command.add_option("--voices", arguments.sound.voices, "sound: voices mixed")
                     ->check(wholeNumberIn(0, kMostVoices))
                     ->capture_default_str();
  given.background_voices =
      command
          .add_option("--background-voices", arguments.sound.background_voices,
                      "sound: of the voices, always sounding (at most --voices)")
          ->check(wholeNumberIn(0, kMostVoices))
          ->capture_default_str();
  given.agents = command.add_option("--agents", arguments.ai.agents, "AI: steering agents")
                     ->check(wholeNumberIn(0, kMostAgents))
                     ->capture_default_str();
  // The knob sizes the tasks itself: with the tasks off, or sized by hand, it is a mistake.
  for (CLI::Option* other : {given.no_tasks, given.voices, given.background_voices, given.agents}) {
    task_load->excludes(other);
  }
}

// Where the run writes: --wav, --no-wav, --out, --capture-every, --capture-size.
void addOutputOptions(CLI::App& command, RunArguments& arguments, RunOptionHandles& given) {
  given.wav = command
                  .add_option("--wav", arguments.wav,
                              "the WAV file the run's sound mix goes to (a FIFO or device is "
                              "written through)")
                  ->default_str("OUT/sound.wav");
  given.no_wav = addFlag(command, "--no-wav", arguments.no_wav, "write no WAV");
  command
      .add_option("--out", arguments.out,
                  "output folder; a run replaces the outputs of the last run there, and only "
                  "those (a capture's folder is refused)")
      ->capture_default_str();
  given.capture_every =
      command
          .add_option("--capture-every", arguments.capture_every,
                      "write every K-th frame as a PNG under OUT/frames (0: none)")
          ->check(wholeNumberIn(0, kMostFrames))
          ->default_str("frames 0, F/4, F/2 and 3F/4 of F: " + std::to_string(kDefaultKeyframes) +
                        " PNGs (fewer under 4 frames)");
  given.capture_size =
      command.add_option("--capture-size", arguments.capture_size, "PNG size WIDTHxHEIGHT")
          ->capture_default_str();
}

}  // namespace

void addRunCommand(CLI::App& app) {
  auto arguments = std::make_shared<RunArguments>();
  auto given = std::make_shared<RunOptionHandles>();
  CLI::App* command = app.add_subcommand(
      "run",
      "step a scene through the frame scheduler; write frames.csv, summary.json, "
      "timeline.json, the sound as a WAV and keyframe PNGs.  With no options: the demo, scene 4 "
      "with " +
          std::to_string(kDemoObjects) + " boxes for " + std::to_string(kDemoFrames) +
          " frames (its time on two cores: docs/results/run_costs.md); --paper for the paper's "
          "full run");
  arguments->scene.addTo(*command, kDemoObjects);
  addAlgorithmOption(*command, arguments->algorithm);
  given->frames =
      command->add_option("--frames", arguments->frames, "frames to run, each --frame-time long")
          ->check(wholeNumberIn(1, kMostFrames))
          ->capture_default_str();
  addFlag(*command, "--paper", arguments->paper,
          "the paper's full run: --objects " + std::to_string(kPaperObjects) + " --frames " +
              std::to_string(kPaperFrames) +
              " (about half an hour on two cores without a GPU); either given explicitly wins");
  arguments->physics.addTo(*command);
  addFrameOptions(*command, *arguments, *given);
  addTaskOptions(*command, *arguments, *given);
  addOutputOptions(*command, *arguments, *given);
  addQuietFlag(*command, arguments->quiet);
  command->footer(
      "Examples:\n"
      "  overlap run                                  # the demo, into ./out\n"
      "  overlap run --paper --algo bvh --out paper   # the paper's scene 4 with Bullet's BVH\n"
      "  overlap run --scene 2 --objects 1000 --frames 300 --no-tasks --out s2");
  command->parse_complete_callback([arguments, given] { refuseConflicts(*arguments, *given); });
  command->callback([arguments, given] { run(*arguments, *given); });
}

}  // namespace overlap::engine
