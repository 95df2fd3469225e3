// Two signals (docs/CLI.md, "Signals"; gpu/base/interrupt.h): one delivered
// twice at once, as timeout(1) sends it to the process and then to its
// group, is one stop, which ends the run cleanly (its line, exit 128 + the
// signal, no temporary left); a second one later ends the process at once
// (tests/gpu/interrupt_test.cpp, where nothing looks at the flag between).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "tests/engine/cli_test_support.h"

namespace {

using namespace overlap::testing;
namespace fs = std::filesystem;

class SecondSignalCliTest : public CliTest {
 protected:
  void SetUp() override {
    CliTest::SetUp();
    fs::create_directories(out_);
  }
};

// Both signals are sent while the run is stopped (SIGSTOP), so both are
// delivered together when it resumes: the second is the first's repeat.
TEST_F(SecondSignalCliTest, TwoSignalsDeliveredTogetherStopTheRunCleanly) {
  const std::vector<std::pair<int, int>> pairs = {
      {SIGTERM, SIGTERM}, {SIGINT, SIGTERM}, {SIGHUP, SIGINT}};
  for (const auto& [first, second] : pairs) {
    const fs::path folder = out_ / "r";
    Started run("run --objects 100 --frames 100000 --capture-every 0 --out " + folder.string(),
                out_ / "err.txt");
    ASSERT_TRUE(run.waitFor("frames,")) << run.stderrText();
    run.signal(SIGSTOP);
    run.signal(first);
    run.signal(second);
    run.signal(SIGCONT);
    const int status = run.wait();
    ASSERT_TRUE(WIFEXITED(status))
        << first << " then " << second << ": killed by " << WTERMSIG(status);
    // The kernel delivers pending signals lowest number first: either is the stop.
    EXPECT_TRUE(WEXITSTATUS(status) == 128 + first || WEXITSTATUS(status) == 128 + second)
        << WEXITSTATUS(status) << ": " << run.stderrText();
    EXPECT_NE(run.stderrText().find("stopped by"), std::string::npos) << run.stderrText();
    EXPECT_FALSE(fs::exists(folder / "frames.csv"));
    EXPECT_FALSE(holdsTemporaries(folder));
  }
}

// timeout(1) itself: its SIGTERM reaches the run twice, and the run still
// stops as after one.
TEST_F(SecondSignalCliTest, TimeoutStopsTheRunCleanly) {
  const fs::path folder = out_ / "t";
  // Three seconds: past the start-up of a sanitizer's build, whose handlers
  // must be in place when the signal comes.
  const Result result =
      runCommand("timeout 3 " + std::string(OVERLAP_BINARY) +
                 " run --objects 100 --frames 100000 --capture-every 0 --out " + folder.string());
  const std::string& err = result.stderr_text;
  EXPECT_EQ(result.exit_code, 124) << err;  // timeout's own: the run it timed out ended
  EXPECT_NE(err.find("stopped by SIGTERM"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(folder / "frames.csv"));
  EXPECT_FALSE(holdsTemporaries(folder));
}

}  // namespace
