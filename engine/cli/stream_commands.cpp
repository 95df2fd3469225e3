// `overlap record` and `overlap pairs`: recorded AABB streams in and out.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "engine/cli/commands.h"
#include "engine/cli/physics_options.h"
#include "engine/program/memory_bound.h"
#include "engine/program/number_options.h"
#include "engine/program/output_checks.h"
#include "engine/program/program_runner.h"
#include "engine/program/progress.h"
#include "engine/program/scene_options.h"
#include "engine/program/summary_output.h"
#include "engine/program/usage_error.h"
#include "engine/program/wording.h"
#include "engine/runtime/run_summary.h"
#include "engine/runtime/statistics.h"
#include "engine/streams/recorded_streams.h"
#include "gpu/base/interrupt.h"
#include "gpu/base/output_file.h"
#include "gpu/base/stopwatch.h"
#include "physics/aabb_stream.h"
#include "physics/broadphase_replay.h"

namespace overlap::engine {
namespace {

struct RecordOptions {
  SceneOptions scene;
  int frames = 2048;
  PhysicsOptions physics;
  std::filesystem::path out;
  bool quiet = false;
};

void record(const RecordOptions& options) {
  const physics::SceneConfig config = options.scene.resolve();
  prepareStreamOutput(options.out, config.objects, options.frames);
  physics::AabbStream stream;
  FrameSummary frames(config.frame_time);
  try {
    stream = recordStream(config, options.frames, "overlap record",
                          options.physics.resolve("bvh", config), &frames);
  } catch (const std::invalid_argument& error) {  // a scene the options cannot build
    throw UsageError(std::string("--") + error.what());
  }
  Progress writing("overlap record: writing " + oneLine(options.out.string()), 0);
  physics::writeAabbStream(options.out, stream);
  writing.finish();
  std::fprintf(stderr, "overlap record: wrote %s (%s, the start and %s)\n",
               oneLine(options.out.string()).c_str(), counted(stream.objects, "object").c_str(),
               counted(stream.stored_frames - 1, "frame").c_str());
  printSummary(options.quiet,
               "overlap record: " + counted(frames.frames(), "frame") + " of scene " +
                   std::to_string(config.scene) + ", " + std::to_string(config.objects) +
                   " boxes, bvh (a frame: its physics step)",
               frames.lines());
}

struct PairsOptions {
  std::optional<std::string> algorithm;  // unset: the box-count rule
  std::filesystem::path input;
  std::uint64_t max_memory_mb = 0;
  bool quiet = false;
};

// `pairs`' summary: a frame's search and the pairs it found.
void printPairsSummary(const PairsOptions& options, const physics::BroadphaseReplay& replay,
                       int objects, const std::vector<double>& search_ms,
                       const std::vector<double>& pairs) {
  const FrameSpread search = spreadOf(search_ms);
  const double most = pairs.empty() ? 0.0 : *std::max_element(pairs.begin(), pairs.end());
  printSummary(
      options.quiet,
      "overlap pairs: " + counted(static_cast<long long>(pairs.size()), "frame") + " of " +
          std::to_string(objects) + " boxes, " + replay.algorithm(),
      {"pairs       " + threeDigits(mean(pairs)) + " a frame (mean), at most " +
           fixedText(most, 0) + ", " +
           fixedText(std::accumulate(pairs.begin(), pairs.end(), 0.0), 0) + " in all",
       "search      median " + threeDigits(search.median) + " ms, p95 " + threeDigits(search.p95) +
           ", max " + threeDigits(search.max) + " (writing the boxes and finding the pairs)"});
}

// Frame by frame, so a stream without a size (a pipe) needs memory for one
// frame only.  A file with a size is checked whole first: a bad box in it
// leaves stdout empty.  From a pipe, the rows of the frames before a bad one
// are printed before the error; the exit status says the stream was bad.
void printPairs(const PairsOptions& options) {
  std::string csv = "frame,a,b\n";
  int frame = 0;
  int frames_sent = 0;  // frames whose rows went to stdout
  refuseStandardOutputOverInput(options.input, "--input");
  try {
    physics::AabbStreamReader reader(options.input);
    if (reader.sized()) reader.checkAll();
    const physics::AabbStreamHeader& header = reader.header();
    const ChosenAlgorithm chosen = chooseAlgorithm(options.algorithm, header.objects);
    const std::string& algorithm = chosen.name;
    requireMemory(replayBytes(algorithm, static_cast<std::uint64_t>(header.objects)),
                  options.max_memory_mb,
                  "--input " + options.input.string() + ": a frame of " +
                      std::to_string(header.objects) + " boxes with --algo " + algorithm);
    checkBroadphaseCapacity("--algo", algorithm, header.objects);
    // The broadphase is sized once a whole frame has arrived: a header's
    // count alone never allocates.
    std::vector<physics::Aabb> boxes;
    reader.next(boxes);
    physics::BroadphaseReplay replay(algorithm, header.world, header.objects);
    if (!chosen.default_reason.empty()) {
      std::fprintf(stderr, "overlap: %s\n", chosen.default_reason.c_str());
    }
    if (!replay.notice().empty()) std::fprintf(stderr, "overlap: %s\n", replay.notice().c_str());
    // The pairs get what the boxes leave of the limit.
    const std::uint64_t box_bytes =
        replayBytes(algorithm, static_cast<std::uint64_t>(header.objects));
    // A frame's CSV rows are held before they are written: "F,A,B\n".
    const std::uint64_t row_bytes =
        std::to_string(header.stored_frames).size() + 2 * std::to_string(header.objects).size() + 3;
    replay.setPairMemoryLimit(pairMemoryLimit(box_bytes, options.max_memory_mb), row_bytes);

    Progress progress("overlap pairs", header.stored_frames);
    std::vector<double> search_ms;
    std::vector<double> pair_counts;
    do {
      stopIfInterrupted("frame " + std::to_string(frame) + " of " +
                        std::to_string(header.stored_frames));
      try {  // Bullet's own broadphases find pairs as the boxes are written
        const HostStopwatch search;
        replay.update(boxes);
        replay.findPairs([&] {
          return "frame " + std::to_string(frame) + " of " + std::to_string(header.stored_frames) +
                 ", its pair search";
        });
        search_ms.push_back(search.ms());
      } catch (const physics::PairMemoryError& error) {
        throw pairMemoryRefusal(error, options.max_memory_mb,
                                "--input " + options.input.string() + ", frame " +
                                    std::to_string(frame) + " with --algo " + algorithm);
      } catch (const std::invalid_argument& error) {  // boxes sap's grid cannot hold
        throw UsageError("--input " + options.input.string() + ", frame " + std::to_string(frame) +
                         ": " + error.what());
      }
      const physics::PairList pairs = replay.pairs();  // read back from the cache once
      pair_counts.push_back(static_cast<double>(pairs.size()));
      for (const auto& [a, b] : pairs) {
        csv += std::to_string(frame) + ',' + std::to_string(a) + ',' + std::to_string(b) + '\n';
      }
      if (csv.size() > (1 << 20)) {
        writeStandardOutput(csv);
        csv.clear();
        frames_sent = frame + 1;
      }
      progress.update(++frame);
    } while (reader.next(boxes));
    progress.finish();
    writeStandardOutput(csv);
    printPairsSummary(options, replay, header.objects, search_ms, pair_counts);
  } catch (Interrupted& stop) {
    // The rows already on stdout stay there: the stop line says which.
    if (frames_sent > 0) {
      stop.already_sent = "standard output's rows of " +
                          (frames_sent == 1 ? std::string("frame 0")
                                            : "frames 0 to " + std::to_string(frames_sent - 1));
    }
    throw;
  } catch (const physics::AabbStreamError& error) {
    // From a pipe, the frames before the bad one (a file was checked first).
    if (frame > 0) writeStandardOutput(csv);
    throw UsageError(error.what());
  }
}

}  // namespace

void addRecordCommand(CLI::App& app) {
  auto options = std::make_shared<RecordOptions>();
  CLI::App* command =
      app.add_subcommand("record", "run a scene and write its AABBs as a Broadmark .aabbs file");
  options->scene.addTo(*command);
  command
      ->add_option("--frames", options->frames,
                   "frames to record, each --frame-time long (F; F + 1 are stored)")
      ->check(wholeNumberIn(1, kMostFrames))
      ->capture_default_str();
  options->physics.addTo(*command);
  command->add_option("--out", options->out, "the .aabbs file to write")->required();
  addQuietFlag(*command, options->quiet);
  command->footer(
      "Example:\n"
      "  overlap record --scene 4 --objects 1000 --frames 120 --out scene4.aabbs");
  command->callback([options] { record(*options); });
}

void addPairsCommand(CLI::App& app) {
  auto options = std::make_shared<PairsOptions>();
  CLI::App* command = app.add_subcommand(
      "pairs", "print each frame's pairs of a .aabbs file as CSV (frame,a,b) on stdout");
  addAlgorithmOption(*command, options->algorithm);
  command
      ->add_option("--input", options->input,
                   "a Broadmark .aabbs file, or a pipe or device streaming one")
      ->required();
  addMaxMemoryOption(*command, options->max_memory_mb);
  addQuietFlag(*command, options->quiet);
  command->footer(
      "Example:\n"
      "  overlap pairs --algo cpubf --input scene4.aabbs > pairs.csv");
  command->callback([options] { printPairs(*options); });
}

}  // namespace overlap::engine
