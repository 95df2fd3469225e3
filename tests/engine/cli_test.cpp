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

namespace {

struct Result {
  int exit_code;
  std::string stderr_text;
};

// Runs the overlap binary with `args`, capturing stderr.
Result runOverlap(const std::string& args) {
  // One stderr file per test: ctest runs the tests in parallel processes.
  const std::filesystem::path err =
      std::filesystem::temp_directory_path() /
      ("overlap_cli_err_" +
       std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + ".txt");
  const std::string command =
      std::string(OVERLAP_BINARY) + " " + args + " > /dev/null 2> " + err.string();
  const int status = std::system(command.c_str());
  std::ifstream in(err);
  std::stringstream text;
  text << in.rdbuf();
  return {WEXITSTATUS(status), text.str()};
}

int lineCount(const std::string& text) {
  return static_cast<int>(std::count(text.begin(), text.end(), '\n'));
}

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    out_ = std::filesystem::temp_directory_path() /
           ("overlap_cli_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    std::filesystem::remove_all(out_);
  }
  void TearDown() override { std::filesystem::remove_all(out_); }
  std::filesystem::path out_;
};

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
      "--ccd --no-tasks --out " +
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

TEST_F(CliTest, CaptureThatCannotRenderFailsWithoutWritingAnImage) {
  for (const char* size : {"0x0", "100000x100000", "wide"}) {
    const Result result = runOverlap(std::string("capture --objects 100 --keyframes 1 --size ") +
                                     size + " --out " + out_.string());
    EXPECT_NE(result.exit_code, 0) << size;
    EXPECT_FALSE(result.stderr_text.empty()) << size;
    EXPECT_FALSE(std::filesystem::exists(out_ / "scene4_frame0001.png")) << size;
  }
}

TEST_F(CliTest, RunCapturesEveryKthFrameOutsideThePhysicsTimings) {
  ASSERT_EQ(
      runOverlap("run --objects 100 --frames 7 --capture-every 3 --capture-size 64x48 --out " +
                 out_.string())
          .exit_code,
      0);
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

// Runs `overlap ARGS`, returning its stdout (stderr is dropped).
std::string stdoutOf(const std::string& args, int* exit_code) {
  std::string output;
  FILE* pipe = popen((std::string(OVERLAP_BINARY) + " " + args + " 2>/dev/null").c_str(), "r");
  char buffer[4096];
  for (std::size_t got; (got = std::fread(buffer, 1, sizeof(buffer), pipe)) > 0;) {
    output.append(buffer, got);
  }
  *exit_code = WEXITSTATUS(pclose(pipe));
  return output;
}

std::string fileText(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
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
}

TEST_F(CliTest, WavAndTasksAreDeterministicAndCompareSyncMatches) {
  const std::string args =
      "run --objects 100 --frames 10 --voices 8 --background-voices 2 "
      "--agents 16 --compare-sync ";
  ASSERT_EQ(
      runOverlap(args + "--wav " + (out_ / "a.wav").string() + " --out " + out_.string()).exit_code,
      0);
  ASSERT_EQ(
      runOverlap(args + "--wav " + (out_ / "b.wav").string() + " --out " + out_.string()).exit_code,
      0);
  const std::string a = fileText(out_ / "a.wav");
  EXPECT_EQ(a.substr(0, 4), "RIFF");
  EXPECT_EQ(a.size(), 44u + 10u * 1600u * 4u);
  EXPECT_EQ(a, fileText(out_ / "b.wav"));

  std::ifstream summary_file(out_ / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(summary_file);
  EXPECT_TRUE(summary["compare_sync"]["identical_state"].get<bool>());
  EXPECT_TRUE(summary["compare_sync"]["identical_tasks"].get<bool>());
  EXPECT_GT(summary["compare_sync"]["speedup"].get<double>(), 0.0);
  const nlohmann::json timeline = nlohmann::json::parse(fileText(out_ / "timeline.json"));
  EXPECT_GT(timeline["traceEvents"].size(), 10u * 4u);
}

}  // namespace
