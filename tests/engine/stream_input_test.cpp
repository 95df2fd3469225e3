// The streams as a user handles them: `overlap generate` writes a stream
// that `overlap pairs` and `overlap_bench_broadphase --input` read, and the
// benchmark refuses a bad stream with exit 2, naming it, writing nothing; its
// GPU columns are filled for the GPU finders only.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "tests/engine/cli_test_support.h"
#include "tests/needs_device.h"

namespace overlap::testing {
namespace {

class StreamInputTest : public CliTest {
 protected:
  void SetUp() override {
    CliTest::SetUp();
    std::filesystem::create_directories(out_);
  }
  std::string bench(const std::string& args) const {
    return std::string(OVERLAP_BENCH_BINARY) + " " + args + " --out " + (out_ / "bench").string();
  }
};

TEST_F(StreamInputTest, AGeneratedStreamIsTimedByEveryAskedBroadphase) {
  const std::filesystem::path a = out_ / "a.aabbs", b = out_ / "b.aabbs";
  ASSERT_EQ(runOverlap("generate --scene 4 --objects 300 --frames 3 --out " + a.string()).exit_code,
            0);
  ASSERT_EQ(runOverlap("generate --scene 1 --objects 200 --frames 2 --out " + b.string()).exit_code,
            0);
  const Result result =
      runCommand(bench("--input " + a.string() + " " + b.string() +
                       " --algos bvh,cpubf,cpusap --warmup 1 --repeats 1 --churn 0.1"));
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  std::stringstream csv(fileText(out_ / "bench.csv"));
  // Three algorithms, with and without churn, on each of the two streams.
  int rows = 0;
  for (std::string line; std::getline(csv, line);)
    rows += line.starts_with("300,") || line.starts_with("200,");
  EXPECT_EQ(rows, 12) << csv.str();
  // --stream-stats writes no results: an --out would be refused as ignored.
  EXPECT_EQ(runCommand(std::string(OVERLAP_BENCH_BINARY) + " --input " + a.string() +
                       " --stream-stats --warmup 1")
                .exit_code,
            0);
}

TEST_F(StreamInputTest, AStreamFromAPipeIsTimedAsTheSameStreamFromAFile) {
  const std::filesystem::path a = out_ / "a.aabbs";
  ASSERT_EQ(runOverlap("generate --scene 4 --objects 200 --frames 3 --out " + a.string()).exit_code,
            0);
  // The header is read once, by the reader that then reads the frames: a
  // pipe cannot be opened again at its start.
  const Result piped =
      runCommand("cat " + a.string() + " | " +
                 bench("--input /dev/stdin --algos cpusap --warmup 1 --repeats 1"));
  ASSERT_EQ(piped.exit_code, 0) << piped.stderr_text;
  std::stringstream csv(fileText(out_ / "bench.csv"));
  int rows = 0;
  for (std::string line; std::getline(csv, line);) rows += line.starts_with("200,");
  EXPECT_EQ(rows, 1) << csv.str();
}

TEST_F(StreamInputTest, TheGpuColumnsHoldWhatTheGpuFindersDidAndNothingForTheOthers) {
  for (const char* algorithm : {"gpubf", "gpubf-paper"}) OVERLAP_NEEDS_DEVICE_FOR(algorithm);
  const std::filesystem::path a = out_ / "a.aabbs";
  ASSERT_EQ(runOverlap("generate --scene 4 --objects 300 --frames 3 --out " + a.string()).exit_code,
            0);
  const Result result = runCommand(bench(
      "--input " + a.string() + " --algos bvh,cpubf,gpubf,gpubf-paper --warmup 1 --repeats 1"));
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  std::ifstream json_file(out_ / "bench.json");
  const nlohmann::json rows = nlohmann::json::parse(json_file)["rows"];
  ASSERT_EQ(rows.size(), 4u);
  for (const nlohmann::json& row : rows) {
    SCOPED_TRACE(row["algorithm"].get<std::string>());
    const bool gpu = row["algorithm"] == "gpubf" || row["algorithm"] == "gpubf-paper";
    EXPECT_EQ(row["launch_to_finish_us"].is_null(), row["algorithm"] == "bvh");
    for (const char* column :
         {"upload_us", "kernels_us", "download_us", "bytes_to_device", "bytes_from_device",
          "api_calls", "host_bytes_copied", "host_entries_sorted"}) {
      EXPECT_EQ(row[column].is_null(), !gpu) << column;
    }
    if (!gpu) continue;
    EXPECT_EQ(row["bytes_to_device"], 32 * 300);  // every box, every frame
    EXPECT_GT(row["api_calls"].get<double>(), 0);
  }
  // gpubf: the broadphase fills its staging and the device sorts the changes.
  EXPECT_EQ(rows[2]["host_bytes_copied"], 0);
  EXPECT_EQ(rows[2]["host_entries_sorted"], 0);
  // gpubf-paper: a byte per pair back.
  EXPECT_EQ(rows[3]["bytes_from_device"], 300 * 299 / 2);
}

TEST_F(StreamInputTest, ABadStreamExitsWith2NamingItAndWritesNothing) {
  const std::filesystem::path bad = out_ / "bad.aabbs";
  std::ofstream(bad) << "not a stream";
  const Result result =
      runCommand(bench("--input " + bad.string() + " --algos cpusap --repeats 1"));
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.stderr_text.find(bad.string()), std::string::npos) << result.stderr_text;
  EXPECT_FALSE(std::filesystem::exists(out_ / "bench.csv"));
  EXPECT_EQ(runCommand(bench("--input " + (out_ / "missing.aabbs").string())).exit_code, 2);
}

}  // namespace
}  // namespace overlap::testing
