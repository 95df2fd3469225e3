// `overlap` as a user runs it: exit codes, messages, outputs.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "tests/engine/cli_test_support.h"
#include "tests/needs_device.h"

namespace {

using namespace overlap::testing;

TEST_F(CliTest, BadOptionsPrintOneLineAndExitWith2) {
  const std::array<std::string, 13> bad = {
      "run --objects -5",        "run --objects lots", "run --algo octree",
      "run --scene 7",           "run --frames 0",     "run --substeps 0",
      "run --fill 0.9",          "run --no-such-flag", "run --small-sizes 0.5 0.2",
      "run --substeps fast",     "run --ccd some",     "run --sleep maybe",
      "run --scene 3 --sleep on"};
  for (const std::string& args : bad) {
    const Result result = runOverlap(args + " --out " + out_.string());
    EXPECT_EQ(result.exit_code, 2) << args << ": " << result.stderr_text;
    EXPECT_EQ(lineCount(result.stderr_text), 1) << args << ": " << result.stderr_text;
    EXPECT_FALSE(std::filesystem::exists(out_ / "frames.csv")) << args;
  }
}

TEST_F(CliTest, MissingSubcommandIsAUsageError) {
  EXPECT_EQ(runOverlap("").exit_code, 2);
  EXPECT_EQ(runOverlap("fly").exit_code, 2);
}

TEST_F(CliTest, UnwritableOutFailsBeforeTheRun) {
  const Result result = runOverlap("run --objects 100 --frames 5 --out /proc/overlap-out");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.stderr_text.find("/proc/overlap-out"), std::string::npos) << result.stderr_text;
}

TEST_F(CliTest, OutputFileThatIsADirectoryFailsBeforeTheRun) {
  std::filesystem::create_directories(out_ / "folder");
  for (const std::string& args :
       {"run --objects 50 --frames 2 --capture-every 0 --wav " + (out_ / "folder").string() +
            " --out " + out_.string(),
        "record --objects 50 --frames 2 --out " + (out_ / "folder").string()}) {
    const Result result = runOverlap(args);
    EXPECT_EQ(result.exit_code, 2) << args << ": " << result.stderr_text;
    EXPECT_NE(result.stderr_text.find((out_ / "folder").string() + ": is a directory"),
              std::string::npos)
        << result.stderr_text;
    EXPECT_FALSE(std::filesystem::exists(out_ / "frames.csv")) << args;
  }
}

TEST_F(CliTest, RunWritesFramesAndSummary) {
  const Result result = runOverlap(
      "run --scene 2 --objects 100 --frames 12 --algo bf --seed 5 --out " + out_.string());
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;

  std::ifstream csv(out_ / "frames.csv");
  std::string header;
  std::getline(csv, header);
  for (const char* column :
       {"frame", "update_ms", "broadphase_ms", "narrowphase_ms", "solver_ms", "total_ms", "pairs",
        "escaped", "sunk", "max_penetration", "substeps", "ccd_bodies", "sleeping"}) {
    EXPECT_NE(header.find(column), std::string::npos) << column;
  }
  int rows = 0;
  for (std::string line; std::getline(csv, line);) ++rows;
  EXPECT_EQ(rows, 12);

  std::ifstream summary_file(out_ / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(summary_file);
  EXPECT_EQ(summary["parameters"]["scene"], 2);
  EXPECT_EQ(summary["parameters"]["objects"], 100);
  EXPECT_EQ(summary["parameters"]["seed"], 5);
  EXPECT_EQ(summary["parameters"]["algorithm"], "bf");
  EXPECT_EQ(summary["parameters"]["substeps"], "auto");
  EXPECT_EQ(summary["parameters"]["ccd"], "auto");
  EXPECT_EQ(summary["parameters"]["sleep"], "scene");
  EXPECT_GE(summary["counts"]["substeps"]["mean"].get<double>(), 1.0);
  EXPECT_EQ(summary["parameters"]["gravity_scale"], 1.0);
  for (const char* column : {"update_ms", "broadphase_ms", "total_ms"}) {
    EXPECT_TRUE(summary["timings_ms"][column].contains("median")) << column;
  }
  for (const char* key :
       {"cpu", "hardware_threads", "gpu", "compiler", "build_type", "git_commit"}) {
    EXPECT_TRUE(summary["machine"].contains(key)) << key;
  }
  EXPECT_FALSE(std::filesystem::exists(out_ / "frames.csv.partial"));
}

TEST_F(CliTest, FixedSubstepsAndTheOldCcdFlagStillWork) {
  const Result result = runOverlap(
      "run --scene 3 --objects 100 --frames 3 --algo bvh --substeps 3 "
      "--ccd all --no-tasks --out " +
      out_.string());
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  std::ifstream summary_file(out_ / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(summary_file);
  EXPECT_EQ(summary["parameters"]["substeps"], 3);
  EXPECT_EQ(summary["parameters"]["ccd"], "all");
  EXPECT_EQ(summary["counts"]["substeps"]["mean"].get<double>(), 3.0);
  EXPECT_EQ(summary["counts"]["ccd_bodies"]["max"].get<double>(), 100.0);
}

TEST_F(CliTest, SameSeedGivesTheSameStateHash) {
  auto hashOf = [&](const std::string& seed) {
    const Result result = runOverlap("run --scene 4 --objects 100 --frames 20 --seed " + seed +
                                     " --out " + out_.string());
    EXPECT_EQ(result.exit_code, 0) << result.stderr_text;
    std::ifstream summary_file(out_ / "summary.json");
    return nlohmann::json::parse(summary_file)["state_hash"].get<std::string>();
  };
  const std::string first = hashOf("42");
  EXPECT_EQ(first, hashOf("42"));
  EXPECT_NE(first, hashOf("43"));
}

TEST_F(CliTest, CaptureWritesOneIdenticalPngPerKeyframe) {
  const std::string args = "capture --scene 4 --objects 100 --keyframes 0,3 --size 160x120 --out ";
  ASSERT_EQ(runOverlap(args + out_.string()).exit_code, 0);
  const std::filesystem::path second = out_ / "again";
  ASSERT_EQ(runOverlap(args + second.string()).exit_code, 0);
  for (const char* name : {"scene4_frame0000.png", "scene4_frame0003.png"}) {
    std::ifstream a(out_ / name, std::ios::binary), b(second / name, std::ios::binary);
    const std::string first_bytes{std::istreambuf_iterator<char>(a), {}};
    const std::string second_bytes{std::istreambuf_iterator<char>(b), {}};
    ASSERT_GT(first_bytes.size(), 24u) << name;
    EXPECT_EQ(first_bytes.substr(1, 3), "PNG") << name;
    // IHDR: width and height, big-endian, at bytes 16 and 20.
    auto be32 = [&](std::size_t at) {
      return (static_cast<unsigned char>(first_bytes[at]) << 24) |
             (static_cast<unsigned char>(first_bytes[at + 1]) << 16) |
             (static_cast<unsigned char>(first_bytes[at + 2]) << 8) |
             static_cast<unsigned char>(first_bytes[at + 3]);
    };
    EXPECT_EQ(be32(16), 160);
    EXPECT_EQ(be32(20), 120);
    EXPECT_EQ(first_bytes, second_bytes) << name;
  }
}

TEST_F(CliTest, ImageSizeThatCannotBeRenderedIsABadValue) {
  // --size is capture's old name for --capture-size, kept as a hidden alias.
  for (const std::string option : {"capture --size", "capture --capture-size"}) {
    for (const char* size : {"0x0", "100000x100000", "wide"}) {
      const Result result =
          runOverlap(option + " --objects 100 --keyframes 1 " + size + " --out " + out_.string());
      EXPECT_EQ(result.exit_code, 2) << option << " " << size << ": " << result.stderr_text;
      EXPECT_EQ(lineCount(result.stderr_text), 1) << result.stderr_text;
      EXPECT_NE(result.stderr_text.find(size), std::string::npos) << result.stderr_text;
      EXPECT_FALSE(std::filesystem::exists(out_ / "scene4_frame0001.png")) << size;
    }
  }
  const Result run = runOverlap("run --objects 100 --frames 2 --capture-size 100000x100000 --out " +
                                out_.string());
  EXPECT_EQ(run.exit_code, 2) << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("--capture-size 100000x100000"), std::string::npos)
      << run.stderr_text;
  EXPECT_FALSE(std::filesystem::exists(out_ / "frames.csv"));
}

TEST_F(CliTest, RunCapturesEveryKthFrameOutsideThePhysicsTimings) {
  ASSERT_EQ(runOverlap("run --objects 100 --frames 7 --capture-every 3 --capture-size 64x48 "
                       "--no-wav --out " +
                       out_.string())
                .exit_code,
            0);
  EXPECT_FALSE(std::filesystem::exists(out_ / "sound.wav"));
  for (const char* name :
       {"scene4_frame0000.png", "scene4_frame0003.png", "scene4_frame0006.png"}) {
    EXPECT_TRUE(std::filesystem::exists(out_ / "frames" / name)) << name;
  }
  EXPECT_FALSE(std::filesystem::exists(out_ / "frames" / "scene4_frame0001.png"));
  std::ifstream csv(out_ / "frames.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_NE(header.find("render_ms"), std::string::npos);
}

TEST_F(CliTest, RecordThenPairsGivesSortedPairsForEveryStoredFrame) {
  std::filesystem::create_directories(out_);
  const std::filesystem::path stream = out_ / "scene4.aabbs";
  ASSERT_EQ(
      runOverlap("record --scene 4 --objects 100 --frames 3 --out " + stream.string()).exit_code,
      0);
  EXPECT_EQ(std::filesystem::file_size(stream), 304u + 4u * 100u * 32u);

  int exit_code = -1;
  const std::string exact = stdoutOf("pairs --algo bf --input " + stream.string(), &exit_code);
  ASSERT_EQ(exit_code, 0);
  std::istringstream lines(exact);
  std::string line;
  std::getline(lines, line);
  EXPECT_EQ(line, "frame,a,b");
  std::tuple<int, int, int> previous{-1, -1, -1};
  std::set<int> frames;
  int rows = 0;
  while (std::getline(lines, line)) {
    int frame = 0, a = 0, b = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%d,%d,%d", &frame, &a, &b), 3) << line;
    EXPECT_LT(a, b);
    EXPECT_LT(previous, std::make_tuple(frame, a, b)) << "not sorted at " << line;
    previous = {frame, a, b};
    frames.insert(frame);
    ++rows;
  }
  EXPECT_GT(rows, 0);
  EXPECT_LE(*frames.rbegin(), 3);
  EXPECT_EQ(stdoutOf("pairs --algo cpubf --input " + stream.string(), &exit_code), exact);
  EXPECT_EQ(exit_code, 0);
}

// Boxes that left the simulation, recorded: at 50000 g every box leaves the
// simulation at frame 61 (too far from the origin).  Those boxes are stored
// parked outside the world, so `pairs` reads the file and finds no pair for
// them, as the simulation's pair cache has none.
TEST_F(CliTest, RecordWritesBoxesThatLeftTheSimulationSoPairsReadsThem) {
  std::filesystem::create_directories(out_);
  const std::filesystem::path stream = out_ / "lost.aabbs";
  const Result record = runOverlap(
      "record --scene 3 --objects 100 --frames 70 --substeps 1 --ccd off --gravity-scale 50000 "
      "--wall-min 0.5 --wall-fraction 0 --out " +
      stream.string());
  ASSERT_EQ(record.exit_code, 0) << record.stderr_text;
  ASSERT_NE(record.stderr_text.find("left the simulation"), std::string::npos)
      << "the reproduction no longer loses boxes: " << record.stderr_text;
  int last_lost_frame = -1;
  for (std::istringstream lines(record.stderr_text); !lines.eof();) {
    std::string line;
    std::getline(lines, line);
    int box = 0, frame = 0;
    if (std::sscanf(line.c_str(), "overlap: box %d left the simulation at frame %d", &box,
                    &frame) == 2) {
      last_lost_frame = std::max(last_lost_frame, frame);
    }
  }
  ASSERT_GE(last_lost_frame, 0);
  ASSERT_LT(last_lost_frame, 69);

  int exit_code = -1;
  for (const char* algo : {"cpubf", "bf", "sap", "bvh"}) {  // all read it
    const std::string pairs =
        stdoutOf(std::string("pairs --algo ") + algo + " --input " + stream.string(), &exit_code);
    ASSERT_EQ(exit_code, 0) << algo;
    // Every box is gone after frame last_lost_frame: the stored frames after
    // it (stored frame f is after frame f - 1) hold no pair.
    std::istringstream lines(pairs);
    std::string line;
    std::getline(lines, line);
    int rows_after = 0;
    while (std::getline(lines, line)) {
      int frame = 0, a = 0, b = 0;
      ASSERT_EQ(std::sscanf(line.c_str(), "%d,%d,%d", &frame, &a, &b), 3) << line;
      if (frame > last_lost_frame + 1) ++rows_after;
    }
    // bvh's cache drops stale pairs a share per frame (btDbvtBroadphase's
    // incremental clean-up), so only the exact broadphases are held to none.
    if (std::string(algo) != "bvh") {
      EXPECT_EQ(rows_after, 0) << algo;
    }
  }
}

// The GPU finders, run by `overlap` itself where this process sees a CUDA
// device (the emulation build's counts): then `overlap` must run them, not
// fall back to a CPU finder, and their pairs must be cpubf's.
TEST_F(CliTest, PairsFromTheGpuFindersEqualCpubfsByteForByte) {
  const char* const gpu_finders[] = {"gpubf", "gpubf-paper", "gpusap"};
  for (const char* algorithm : gpu_finders) OVERLAP_NEEDS_DEVICE_FOR(algorithm);
  std::filesystem::create_directories(out_);
  const std::filesystem::path stream = out_ / "scene4.aabbs";
  ASSERT_EQ(
      runOverlap("record --scene 4 --objects 300 --frames 20 --out " + stream.string()).exit_code,
      0);
  int exit_code = -1;
  const std::string exact = stdoutOf("pairs --algo cpubf --input " + stream.string(), &exit_code);
  ASSERT_EQ(exit_code, 0);
  ASSERT_GT(lineCount(exact), 100);
  for (const std::string algo : gpu_finders) {
    const std::string args = "pairs --algo " + algo + " --input " + stream.string();
    const Result result = runOverlap(args);
    ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
    EXPECT_EQ(result.stderr_text.find(" instead"), std::string::npos)
        << algo << " fell back to a CPU finder: " << result.stderr_text;
    EXPECT_EQ(stdoutOf(args, &exit_code), exact) << algo;
    EXPECT_EQ(exit_code, 0);
  }
}

// Where this process sees a CUDA device, so does `overlap`: it runs gpubf there.
TEST_F(CliTest, RunWithGpubfNamesTheDeviceItRanOn) {
  OVERLAP_NEEDS_DEVICE_FOR("gpubf");
  const Result result =
      runOverlap("run --scene 4 --objects 150 --frames 6 --algo gpubf --out " + out_.string());
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  std::ifstream summary_file(out_ / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(summary_file);
  EXPECT_EQ(summary["parameters"]["algorithm"], "gpubf");
  const std::string gpu = summary["machine"]["gpu"];
#if OVERLAP_CUDA_EMULATION
  EXPECT_TRUE(gpu.starts_with("CUDA emulation on the CPU, ")) << gpu;
#else
  EXPECT_FALSE(gpu.starts_with("none")) << gpu;
#endif
}

TEST_F(CliTest, PairsRejectsABadFileWithoutWritingToStdout) {
  std::filesystem::create_directories(out_);
  const std::filesystem::path bad = out_ / "bad.aabbs";
  std::ofstream(bad) << "not a stream";
  int exit_code = -1;
  EXPECT_EQ(stdoutOf("pairs --input " + bad.string(), &exit_code), "");
  EXPECT_EQ(exit_code, 2);
  const Result result = runOverlap("pairs --input " + bad.string());
  EXPECT_NE(result.stderr_text.find(bad.string()), std::string::npos) << result.stderr_text;
  EXPECT_EQ(stdoutOf("pairs --input /nonexistent.aabbs", &exit_code), "");
  EXPECT_EQ(exit_code, 2);
  // A directory is unusable input, not the program failing.
  EXPECT_EQ(stdoutOf("pairs --algo cpubf --input " + out_.string(), &exit_code), "");
  EXPECT_EQ(exit_code, 2);
  const Result directory = runOverlap("pairs --algo cpubf --input " + out_.string());
  EXPECT_EQ(lineCount(directory.stderr_text), 1) << directory.stderr_text;
  EXPECT_NE(directory.stderr_text.find(out_.string() + ": is a directory"), std::string::npos)
      << directory.stderr_text;
}

// A bad value exits 2 with one line naming the option and the value, and
// writes nothing; the program's own failures are exit 1.
TEST_F(CliTest, ValuesTheSceneCannotUseExitWith2NamingThem) {
  const std::string out = " --frames 2 --out " + out_.string();
  const std::array<std::pair<std::string, std::string>, 5> bad = {{
      {"run --scene 2 --objects 50 --fill 0.3" + out, "--fill: 0.3"},
      {"record --scene 2 --objects 50 --fill 0.3 --out " + (out_ / "a.aabbs").string(),
       "--fill: 0.3"},
      {"run --scene 4 --kicks 3" + out, "--kicks: scene 4"},
      {"capture --scene 1 --small-sizes 0.1 0.2 --out " + out_.string(), "--small-sizes: scene 1"},
      {"latency --scene 2 --rotation 0.1 --frames 2", "--rotation: scene 2"},
  }};
  for (const auto& [args, message] : bad) {
    const Result result = runOverlap(args);
    EXPECT_EQ(result.exit_code, 2) << args << ": " << result.stderr_text;
    EXPECT_EQ(lineCount(result.stderr_text), 1) << args << ": " << result.stderr_text;
    EXPECT_NE(result.stderr_text.find(message), std::string::npos)
        << args << ": " << result.stderr_text;
    EXPECT_FALSE(std::filesystem::exists(out_ / "frames.csv")) << args;
  }
}

// One box: its container is about 1 m across, smaller than the AI's agents
// and wall margin; the AI adapts and the run completes.
TEST_F(CliTest, RunOfOneObjectCompletes) {
  const Result result = runOverlap("run --objects 1 --frames 2 --out " + out_.string());
  EXPECT_EQ(result.exit_code, 0) << result.stderr_text;
  EXPECT_TRUE(std::filesystem::exists(out_ / "summary.json"));
}

// What `overlap run` leaves without being asked: the tables, the timeline,
// the sound, keyframes, and one line saying where, before the summary.
TEST_F(CliTest, RunWritesEveryOutputAndSaysWhere) {
  const Result result =
      runOverlap("run --objects 60 --frames 8 --capture-size 64x48 --out " + out_.string());
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  const std::filesystem::path frames = out_ / "frames";
  const std::vector<std::filesystem::path> written = {out_ / "frames.csv",
                                                      out_ / "summary.json",
                                                      out_ / "timeline.json",
                                                      out_ / "sound.wav",
                                                      frames / "scene4_frame0000.png",
                                                      frames / "scene4_frame0002.png",
                                                      frames / "scene4_frame0004.png",
                                                      frames / "scene4_frame0006.png"};
  for (const std::filesystem::path& path : written) {
    EXPECT_TRUE(std::filesystem::exists(path)) << path;
  }
  EXPECT_FALSE(std::filesystem::exists(frames / "scene4_frame0001.png"));
  // The line before the summary (the summary is the end of the run's stderr).
  const std::size_t wrote_at = result.stderr_text.find("overlap run: wrote ");
  ASSERT_NE(wrote_at, std::string::npos) << result.stderr_text;
  const std::string wrote_line =
      result.stderr_text.substr(wrote_at, result.stderr_text.find('\n', wrote_at) - wrote_at);
  for (const std::filesystem::path& path :
       std::vector<std::filesystem::path>{out_ / "frames.csv", out_ / "summary.json",
                                          out_ / "timeline.json", out_ / "sound.wav", frames}) {
    EXPECT_NE(wrote_line.find(path.string()), std::string::npos) << path << " in " << wrote_line;
  }
  EXPECT_NE(wrote_line.find("4 PNGs"), std::string::npos) << wrote_line;
  EXPECT_NE(result.stderr_text.find("overlap run: 8 frames", wrote_at), std::string::npos)
      << result.stderr_text;
}

TEST_F(CliTest, VersionPrintsTheVersionAndCommit) {
  int exit_code = -1;
  const std::string version = stdoutOf("--version", &exit_code);
  EXPECT_EQ(exit_code, 0);
  EXPECT_EQ(version.rfind("overlap ", 0), 0u) << version;
  EXPECT_NE(version.find("git "), std::string::npos) << version;
}

TEST_F(CliTest, WavAndTasksAreDeterministicAndCompareSyncMatches) {
  const std::string args =
      "run --objects 100 --frames 10 --voices 8 --background-voices 2 "
      "--agents 16 --compare-sync ";
  // Outside the run's folder: a second run into it would remove the first's
  // outputs there (a folder never mixes runs).
  ASSERT_EQ(
      runOverlap(args + "--wav " + (out_ / "a.wav").string() + " --out " + (out_ / "run").string())
          .exit_code,
      0);
  ASSERT_EQ(
      runOverlap(args + "--wav " + (out_ / "b.wav").string() + " --out " + (out_ / "run").string())
          .exit_code,
      0);
  const std::string a = fileText(out_ / "a.wav");
  EXPECT_EQ(a.substr(0, 4), "RIFF");
  EXPECT_EQ(a.size(), 44u + 10u * 1600u * 4u);
  EXPECT_EQ(a, fileText(out_ / "b.wav"));

  std::ifstream summary_file(out_ / "run" / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(summary_file);
  EXPECT_TRUE(summary["compare_sync"]["identical_state"].get<bool>());
  EXPECT_TRUE(summary["compare_sync"]["identical_tasks"].get<bool>());
  const nlohmann::json& compare = summary["compare_sync"];
  EXPECT_DOUBLE_EQ(compare["speedup"].get<double>(),
                   compare["sync_total_ms_median"].get<double>() /
                       compare["async_total_ms_median"].get<double>());
  // Its spread over the frames, each stepped sync and async, and the load it ran under.
  const std::vector<double> quartiles = compare["speedup_frame_quartiles"];
  ASSERT_EQ(quartiles.size(), 3u);
  EXPECT_LE(quartiles[0], quartiles[1]);
  EXPECT_LE(quartiles[1], quartiles[2]);
  EXPECT_TRUE(compare["load_at_start"].is_number());
  const nlohmann::json timeline = nlohmann::json::parse(fileText(out_ / "run" / "timeline.json"));
  EXPECT_GT(timeline["traceEvents"].size(), 10u * 4u);
}

// The summary a run ends with: its title line, then indented lines to the
// end of stderr; empty when there is none.
std::string summaryOf(const std::string& stderr_text, const std::string& title) {
  const std::size_t at = stderr_text.rfind(title);
  if (at == std::string::npos || (at > 0 && stderr_text[at - 1] != '\n')) return {};
  std::istringstream rest(stderr_text.substr(at));
  std::string line;
  std::getline(rest, line);  // the title
  while (std::getline(rest, line)) {
    if (line.rfind("  ", 0) != 0) return {};  // a line after the summary: it was not the end
  }
  return stderr_text.substr(at);
}

// stderr's lines but the progress lines (the first second of a loaded
// machine decides whether there are any).
std::vector<std::string> linesBesideProgress(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (line.find(" elapsed") != std::string::npos || line.find(" pace ") != std::string::npos ||
        line.find(": done") != std::string::npos) {
      continue;
    }
    lines.push_back(line);
  }
  return lines;
}

struct SummaryCase {
  std::string command;  // the binary and its arguments
  std::string title;
  std::vector<std::string> figures;  // words the summary must hold
};

std::vector<SummaryCase> summaryCases(const std::filesystem::path& out) {
  const std::string overlap = std::string(OVERLAP_BINARY) + " ";
  const std::vector<std::string> frame = {"median",
                                          "p95",
                                          "max",
                                          "over the frame time (33.3 ms)",
                                          "a frame (means): update",
                                          "broadphase",
                                          "other",
                                          "with the update"};
  auto with = [](std::vector<std::string> words, const std::vector<std::string>& more) {
    words.insert(words.end(), more.begin(), more.end());
    return words;
  };
  return {
      {overlap + "record --objects 60 --frames 3 --out " + (out / "s.aabbs").string(),
       "overlap record: 3 frames of scene 4, 60 boxes, bvh", frame},
      {overlap + "pairs --algo bf --input " + (out / "s.aabbs").string(),
       "overlap pairs: 4 frames of 60 boxes, bf",
       {"a frame (mean), at most", "in all", "search"}},
      {overlap + "generate --objects 60 --frames 3 --out " + (out / "g.aabbs").string(),
       "overlap generate: 3 frames of scene 4, 60 boxes",
       {"median", "p95", "max"}},
      {overlap + "capture --objects 40 --keyframes 1 --capture-size 32x24 --out " +
           (out / "capture").string(),
       "overlap capture: 2 frames of scene 4, 40 boxes", frame},
      {overlap + "latency --objects 60 --frames 3 --algo bvh --growth 0,1",
       "overlap latency: 3 frames of scene 4, 60 boxes",
       with(frame, {"algo  growth  exact  missed  extra", "\n    bvh "})},
      {overlap + "run --objects 60 --frames 4 --capture-every 0 --no-wav --out " +
           (out / "run").string(),
       "overlap run: 4 frames of scene 4, 60 boxes", frame},
      {std::string(OVERLAP_BENCH_BINARY) +
           " --objects 40 --big-objects 0 --algos bvh,cpusap --record-frames 3 --warmup 1 "
           "--repeats 1 --streams " +
           (out / "streams").string() + " --out " + (out / "bench").string(),
       "overlap_bench_broadphase: a frame's update + search + pair cache",
       {"median us", "vs bvh", "missed", "40  bvh", "40  cpusap"}},
  };
}

TEST_F(CliTest, EverySubcommandAndTheBenchmarkEndWithTheirSummary) {
  std::filesystem::create_directories(out_);
  for (const SummaryCase& run : summaryCases(out_)) {
    const Result result = runCommand(run.command);
    ASSERT_EQ(result.exit_code, 0) << run.command << ": " << result.stderr_text;
    const std::string summary = summaryOf(result.stderr_text, run.title);
    ASSERT_FALSE(summary.empty()) << run.command << " does not end with '" << run.title << "...':\n"
                                  << result.stderr_text;
    for (const std::string& figure : run.figures) {
      EXPECT_NE(summary.find(figure), std::string::npos) << run.command << ": " << figure << " in\n"
                                                         << summary;
    }
  }
}

TEST_F(CliTest, QuietDropsTheSummaryAndNothingElse) {
  std::filesystem::create_directories(out_);
  // Once first, so that both runs below find what a first run makes (the
  // benchmark's recorded stream) and say the same of it.
  for (const SummaryCase& run : summaryCases(out_)) runCommand(run.command + " --quiet");
  for (const SummaryCase& run : summaryCases(out_)) {
    const Result loud = runCommand(run.command);
    const Result quiet = runCommand(run.command + " --quiet");
    ASSERT_EQ(quiet.exit_code, 0) << run.command << ": " << quiet.stderr_text;
    const std::string summary = summaryOf(loud.stderr_text, run.title);
    ASSERT_FALSE(summary.empty()) << run.command << ": " << loud.stderr_text;
    EXPECT_EQ(quiet.stderr_text.find(run.title), std::string::npos) << quiet.stderr_text;
    const std::string without_summary =
        loud.stderr_text.substr(0, loud.stderr_text.size() - summary.size());
    EXPECT_EQ(linesBesideProgress(quiet.stderr_text), linesBesideProgress(without_summary))
        << run.command;
  }
}

TEST_F(CliTest, SummaryJsonHoldsTheFrameSpreadTheFramesOverAndTheThreadsThatRan) {
  const auto summaryOfRun = [&](const std::string& args) {
    const Result result = runOverlap("run --objects 60 --frames 6 --capture-every 0 --no-wav " +
                                     args + " --out " + out_.string());
    EXPECT_EQ(result.exit_code, 0) << result.stderr_text;
    return nlohmann::json::parse(fileText(out_ / "summary.json"));
  };
  // Nothing asked: the rule picked the broadphase, and every thread oneTBB may use ran.
  const nlohmann::json defaulted = summaryOfRun("");
  EXPECT_TRUE(defaulted["parameters"]["algorithm_requested"].is_null());
  EXPECT_FALSE(defaulted["parameters"]["algorithm"].get<std::string>().empty());
  const int threads = defaulted["parameters"]["threads"];
  EXPECT_GE(threads, 1);
  EXPECT_LE(threads, defaulted["machine"]["hardware_threads"].get<int>());
  for (const auto& [column, figures] : defaulted["timings_ms"].items()) {
    EXPECT_LE(figures["median"].get<double>(), figures["p95"].get<double>()) << column;
    EXPECT_LE(figures["p95"].get<double>(), figures["p99"].get<double>()) << column;
    EXPECT_LE(figures["p99"].get<double>(), figures["max"].get<double>()) << column;
  }
  // The frames over the frame time are frames.csv's rows whose total_ms is over it.
  std::ifstream csv(out_ / "frames.csv");
  std::string header;
  std::getline(csv, header);
  std::vector<std::string> names;
  for (std::stringstream cells(header); std::getline(cells, names.emplace_back(), ',');) {
  }
  const auto total = std::find(names.begin(), names.end(), "total_ms") - names.begin();
  int over = 0;
  for (std::string row; std::getline(csv, row);) {
    std::stringstream cells(row);
    std::string cell;
    for (long i = 0; i <= total; ++i) std::getline(cells, cell, ',');
    if (std::stod(cell) > 1000.0 / 30) ++over;
  }
  EXPECT_EQ(defaulted["frames_over_frame_time"], over);

  const nlohmann::json named =
      summaryOfRun("--algo bf --threads 1 --frame-time 0.000001 --no-tasks");
  EXPECT_EQ(named["parameters"]["algorithm_requested"], "bf");
  EXPECT_EQ(named["parameters"]["threads"], 1);
  EXPECT_EQ(named["frames_over_frame_time"], 6);  // no frame takes under a microsecond
}

TEST_F(CliTest, CompareSyncEndsWithItsSpeedupItsSpreadAndTheLoad) {
  const Result result =
      runOverlap("run --objects 40 --frames 4 --capture-every 0 --no-wav --compare-sync --out " +
                 out_.string());
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  const std::string summary = summaryOf(result.stderr_text, "overlap run: 4 frames");
  ASSERT_FALSE(summary.empty()) << result.stderr_text;
  for (const char* words : {"sync and async", "speed-up    ", "frame by frame", "(quartiles of 4)",
                            "at the start, on "}) {
    EXPECT_NE(summary.find(words), std::string::npos) << words << " in\n" << summary;
  }
}

}  // namespace
