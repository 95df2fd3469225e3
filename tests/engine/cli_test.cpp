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
#include <sstream>
#include <string>

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
  const std::array<std::string, 9> bad = {
      "run --objects -5", "run --objects lots", "run --algo octree",
      "run --scene 7",    "run --frames 0",     "run --substeps 0",
      "run --fill 0.9",   "run --no-such-flag", "run --small-sizes 0.5 0.2"};
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
  for (const char* column : {"frame", "update_ms", "broadphase_ms", "narrowphase_ms", "solver_ms",
                             "total_ms", "pairs", "escaped", "sunk", "max_penetration"}) {
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
  EXPECT_EQ(summary["parameters"]["substeps"], 2);
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

}  // namespace
