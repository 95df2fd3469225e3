// The streams as a user handles them: `overlap generate` writes a stream
// that `overlap pairs` and `overlap_bench_broadphase --input` read, and the
// benchmark refuses a bad stream with exit 2, naming it, writing nothing.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "tests/scratch_path.h"

namespace {

struct Result {
  int exit_code;
  std::string stderr_text;
};

Result run(const std::string& command_line) {
  const std::filesystem::path err = overlap::testing::scratchPath(
      "input_err_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
  const int status = std::system((command_line + " > /dev/null 2> " + err.string()).c_str());
  std::stringstream text;
  text << std::ifstream(err).rdbuf();
  std::filesystem::remove(err);
  return {WEXITSTATUS(status), text.str()};
}

class StreamInputTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = overlap::testing::scratchPath(
        "input_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string bench(const std::string& args) const {
    return std::string(OVERLAP_BENCH_BINARY) + " " + args + " --out " + (dir_ / "bench").string();
  }
  std::filesystem::path dir_;
};

TEST_F(StreamInputTest, AGeneratedStreamIsTimedByEveryAskedBroadphase) {
  const std::filesystem::path a = dir_ / "a.aabbs", b = dir_ / "b.aabbs";
  ASSERT_EQ(run(std::string(OVERLAP_BINARY) +
                " generate --scene 4 --objects 300 --frames 3 --out " + a.string())
                .exit_code,
            0);
  ASSERT_EQ(run(std::string(OVERLAP_BINARY) +
                " generate --scene 1 --objects 200 --frames 2 --out " + b.string())
                .exit_code,
            0);
  const Result result = run(bench("--input " + a.string() + " " + b.string() +
                                  " --algos bvh,cpubf,cpusap --warmup 1 --repeats 1 --churn 0.1"));
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  std::stringstream csv;
  csv << std::ifstream(dir_ / "bench.csv").rdbuf();
  // Three algorithms, with and without churn, on each of the two streams.
  int rows = 0;
  for (std::string line; std::getline(csv, line);)
    rows += line.starts_with("300,") || line.starts_with("200,");
  EXPECT_EQ(rows, 12) << csv.str();
  EXPECT_EQ(run(bench("--input " + a.string() + " --stream-stats --warmup 1")).exit_code, 0);
}

TEST_F(StreamInputTest, ABadStreamExitsWith2NamingItAndWritesNothing) {
  const std::filesystem::path bad = dir_ / "bad.aabbs";
  std::ofstream(bad) << "not a stream";
  const Result result = run(bench("--input " + bad.string() + " --algos cpusap --repeats 1"));
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.stderr_text.find(bad.string()), std::string::npos) << result.stderr_text;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "bench.csv"));
  EXPECT_EQ(run(bench("--input " + (dir_ / "missing.aabbs").string())).exit_code, 2);
}

}  // namespace
