// Programs started with a standard descriptor closed (`2>&-`, `>&-`,
// `<&-`; gpu/base/standard_streams.h): the first file a program opens must
// never take fd 0, 1 or 2, or its messages or rows land in the user's
// outputs (a WAV, an .aabbs stream, a CSV).  Every program the project
// builds that writes files is run with each of the three closed.
#include <gtest/gtest.h>

#include <filesystem>
#include <regex>
#include <string>
#include <vector>

#include "tests/engine/cli_test_support.h"

namespace {

using namespace overlap::testing;
namespace fs = std::filesystem;

// One program's command line writing under `out`, and whether it writes
// rows to standard output (then a closed stdout is a failed write, exit 1).
struct Program {
  std::string command;
  bool writes_stdout = false;
};

std::vector<Program> programs(const fs::path& out, const fs::path& stream) {
  const std::string overlap = std::string(OVERLAP_BINARY) + " ";
  return {
      // No --algo: run says which broadphase it chose, a message on stderr.
      {overlap + "run --objects 30 --frames 4 --capture-every 2 --capture-size 32x24 --out " +
       (out / "run").string()},
      {overlap + "run --objects 30 --frames 3 --capture-every 0 --out " + (out / "run2").string() +
       " --wav " + (out / "elsewhere.wav").string()},
      {overlap + "capture --objects 30 --keyframes 1 --capture-size 32x24 --out " +
       (out / "capture").string()},
      {overlap + "record --objects 30 --frames 3 --out " + (out / "r.aabbs").string()},
      {overlap + "generate --objects 30 --frames 3 --out " + (out / "g.aabbs").string()},
      {overlap + "pairs --algo bf --input " + stream.string(), true},
      {overlap + "latency --objects 30 --frames 3 --algo bvh --growth 0,1", true},
      {std::string(OVERLAP_BENCH_BINARY) +
       " --objects 30 --big-objects 0 --algos bvh,cpusap --record-frames 3 --warmup 1 "
       "--repeats 1 --streams " +
       (out / "streams").string() + " --out " + (out / "bench").string()},
  };
}

// A message any of the programs prints: "overlap: ...", "overlap run: ...",
// "overlap_bench_broadphase: ...".
bool holdsAMessage(const std::string& text) {
  static const std::regex kMessage("overlap(_bench_broadphase| [a-z]+)?: ");
  return std::regex_search(text, kMessage);
}

class ClosedStreamsCliTest : public CliTest {};

TEST_F(ClosedStreamsCliTest, AClosedStandardDescriptorNeverReceivesAnOutputFile) {
  fs::create_directories(out_);
  const fs::path stream = out_ / "input.aabbs";
  ASSERT_EQ(runOverlap("record --objects 30 --frames 2 --out " + stream.string()).exit_code, 0);
  for (const int closed : {0, 1, 2}) {
    const fs::path out = out_ / ("closed" + std::to_string(closed));
    for (const Program& program : programs(out, stream)) {
      fs::create_directories(out);
      // The redirections run left to right: the last one leaves `closed` closed.
      const std::string command = program.command + " < /dev/null > /dev/null 2> /dev/null " +
                                  std::to_string(closed) + ">&-";
      const int status = std::system(command.c_str());
      ASSERT_TRUE(WIFEXITED(status)) << command;
      const int expected = closed == 1 && program.writes_stdout ? 1 : 0;
      EXPECT_EQ(WEXITSTATUS(status), expected) << command;
      for (const auto& entry : fs::recursive_directory_iterator(out)) {
        if (!entry.is_regular_file()) continue;
        EXPECT_FALSE(holdsAMessage(fileText(entry.path())))
            << command << ": " << entry.path() << " holds a message";
      }
      // Every stream written reads back whole: nothing was added to it.
      for (const fs::path& written : {out / "r.aabbs", out / "g.aabbs"}) {
        if (!fs::exists(written)) continue;
        const Result read = runOverlap("pairs --algo bf --input " + written.string());
        EXPECT_EQ(read.exit_code, 0) << command << ": " << written << ": " << read.stderr_text;
      }
      fs::remove_all(out);
    }
  }
}

// What the closed descriptor still does: a write to a closed stdout fails
// and says so (on stderr), as it did when the descriptor was closed.
TEST_F(ClosedStreamsCliTest, AClosedStdoutStillFailsTheRowsWrittenThere) {
  // In braces: the closing comes after runCommand's own redirections.
  const Result result = runCommand("{ " + std::string(OVERLAP_BINARY) +
                                   " latency --objects 30 --frames 2 --algo bvh >&-; }");
  EXPECT_EQ(result.exit_code, 1) << result.stderr_text;
  EXPECT_NE(result.stderr_text.find("standard output: cannot write: Bad file descriptor"),
            std::string::npos)
      << result.stderr_text;
}

}  // namespace
