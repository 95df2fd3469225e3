// A second signal ends the process at once, whatever its kind
// (docs/CLI.md, "Signals"; gpu/base/interrupt.h): a run that a first
// signal has not stopped yet is killed by the second, SIGTERM after SIGINT
// as surely as SIGINT after SIGINT.  (Two of one kind cannot be made
// pending together: the kernel keeps one.)
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
// pending when it resumes: the first is taken as the stop, the second,
// arriving before any frame boundary, must end the process by itself.
TEST_F(SecondSignalCliTest, ASecondSignalOfAnotherKindEndsTheProcess) {
  const std::vector<std::pair<int, int>> pairs = {
      {SIGINT, SIGTERM}, {SIGHUP, SIGTERM}, {SIGINT, SIGHUP}};
  for (const auto& [first, second] : pairs) {
    Started run("run --objects 100 --frames 100000 --capture-every 0 --no-wav --out " +
                    (out_ / "r").string(),
                out_ / "err.txt");
    ASSERT_TRUE(run.waitFor("frames,")) << run.stderrText();
    run.signal(SIGSTOP);
    run.signal(first);
    run.signal(second);
    run.signal(SIGCONT);
    const int status = run.wait();
    EXPECT_TRUE(WIFSIGNALED(status)) << first << " then " << second << ": exit "
                                     << WEXITSTATUS(status) << ": " << run.stderrText();
    if (WIFSIGNALED(status)) {
      EXPECT_TRUE(WTERMSIG(status) == first || WTERMSIG(status) == second) << WTERMSIG(status);
    }
    EXPECT_FALSE(fs::exists(out_ / "r" / "frames.csv"));
  }
}

}  // namespace
