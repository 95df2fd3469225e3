// The streams as a user handles them: `overlap generate` writes a stream
// that `overlap pairs` and `overlap_bench_broadphase --input` read, and the
// benchmark refuses a bad stream with exit 2, naming it, writing nothing.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "tests/engine/cli_test_support.h"

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
