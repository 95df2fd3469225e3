// The signal rules of gpu/base/interrupt.h, in a child process each (a
// death test), where nothing looks at the flag between two signals: the
// first is stored; a repeat within a second is dropped; a later one of any
// kind ends the process by itself.
#include "gpu/base/interrupt.h"

#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <string>
#include <thread>

namespace overlap {
namespace {

class InterruptTest : public ::testing::Test {
 protected:
  void SetUp() override { GTEST_FLAG_SET(death_test_style, "threadsafe"); }
};

TEST_F(InterruptTest, ASignalRepeatedAtOnceIsOneRequest) {
  EXPECT_EXIT(
      {
        catchInterrupts();
        raise(SIGTERM);
        raise(SIGTERM);
        raise(SIGINT);
        std::exit(pendingInterrupt() == SIGTERM ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

TEST_F(InterruptTest, ASecondSignalAfterASecondEndsTheProcessByItself) {
  for (const int second : {SIGINT, SIGTERM, SIGHUP}) {
    EXPECT_EXIT(
        {
          catchInterrupts();
          raise(SIGINT);
          std::this_thread::sleep_for(std::chrono::milliseconds(1100));
          raise(second);
          std::exit(0);
        },
        ::testing::KilledBySignal(second), "")
        << signalName(second);
  }
}

TEST_F(InterruptTest, ASignalIgnoredAtStartStaysIgnored) {
  // nohup ignores SIGHUP, a shell's `trap '' INT` SIGINT: the program must
  // not take them back.
  for (const int ignored : {SIGINT, SIGTERM, SIGHUP}) {
    EXPECT_EXIT(
        {
          std::signal(ignored, SIG_IGN);
          catchInterrupts();
          raise(ignored);
          std::this_thread::sleep_for(std::chrono::milliseconds(1100));
          raise(ignored);
          const bool still_ignored = std::signal(ignored, SIG_IGN) == SIG_IGN;
          std::exit(pendingInterrupt() == 0 && still_ignored ? 0 : 1);
        },
        ::testing::ExitedWithCode(0), "")
        << signalName(ignored);
  }
}

TEST_F(InterruptTest, StopIfInterruptedNamesTheFirstSignalAndWhere) {
  EXPECT_EXIT(
      {
        catchInterrupts();
        raise(SIGHUP);
        try {
          stopIfInterrupted("frame 3 of 9");
        } catch (const Interrupted& stop) {
          std::exit(stop.signal == SIGHUP && std::string(stop.what()) == "SIGHUP at frame 3 of 9"
                        ? 0
                        : 1);
        }
        std::exit(2);
      },
      ::testing::ExitedWithCode(0), "");
}

}  // namespace
}  // namespace overlap
