// Running the `overlap` binary from a test: exit code, stderr, stdout.
#pragma once

#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <utility>

#include "tests/scratch_path.h"

extern char** environ;

namespace overlap::testing {

struct Result {
  int exit_code;
  std::string stderr_text;
};

// Runs `command_line` (a shell command line), capturing stderr.
inline Result runCommand(const std::string& command_line) {
  // One stderr file per test: ctest runs the tests in parallel processes.
  const std::filesystem::path err = overlap::testing::scratchPath(
      "cli_err_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) +
      ".txt");
  const int status = std::system((command_line + " > /dev/null 2> " + err.string()).c_str());
  std::stringstream text;
  text << std::ifstream(err).rdbuf();
  std::filesystem::remove(err);
  return {WEXITSTATUS(status), text.str()};
}

// Runs the overlap binary with `args`, capturing stderr.
inline Result runOverlap(const std::string& args) {
  return runCommand(std::string(OVERLAP_BINARY) + " " + args);
}

inline int lineCount(const std::string& text) {
  // Progress reports ("... 1 s elapsed") are not counted: a slow build (a
  // sanitizer's) may print one before a message that comes after a second.
  int lines = 0;
  std::size_t start = 0;
  for (std::size_t end = text.find('\n'); end != std::string::npos;
       start = end + 1, end = text.find('\n', start)) {
    if (text.substr(start, end - start).find(" elapsed") == std::string::npos) ++lines;
  }
  return lines;
}

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    out_ = overlap::testing::scratchPath(
        "cli_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    std::filesystem::remove_all(out_);
  }
  void TearDown() override { std::filesystem::remove_all(out_); }
  std::filesystem::path out_;
};

// A shell command's stdout and exit code.
inline std::string shellStdout(const std::string& command, int* exit_code) {
  std::string output;
  FILE* pipe = popen(command.c_str(), "r");
  char buffer[4096];
  for (std::size_t got; (got = std::fread(buffer, 1, sizeof(buffer), pipe)) > 0;) {
    output.append(buffer, got);
  }
  *exit_code = WEXITSTATUS(pclose(pipe));
  return output;
}

// Runs `overlap ARGS`, returning its stdout (stderr is dropped).
inline std::string stdoutOf(const std::string& args, int* exit_code) {
  return shellStdout(std::string(OVERLAP_BINARY) + " " + args + " 2>/dev/null", exit_code);
}

inline std::string fileText(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

// A hidden ".NAME.overlap-PID-XXXXXX" temporary left anywhere under `folder`.
inline bool holdsTemporaries(const std::filesystem::path& folder) {
  if (!std::filesystem::exists(folder)) return false;  // a stopped run may leave no folder
  for (const auto& entry : std::filesystem::recursive_directory_iterator(folder)) {
    const std::string name = entry.path().filename().string();
    if (name.front() == '.' && name.find(".overlap-") != std::string::npos &&
        name != ".overlap-outputs") {
      return true;
    }
  }
  return false;
}

// A program started in the background, stderr to a file.
class Started {
 public:
  // `binary` ARGS: the overlap binary unless another is named.
  Started(const std::string& args, std::filesystem::path err,
          const std::string& binary = OVERLAP_BINARY)
      : err_(std::move(err)) {
    const std::string command = "exec " + binary + " " + args + " > /dev/null 2> " + err_.string();
    const char* argv[] = {"/bin/sh", "-c", command.c_str(), nullptr};
    EXPECT_EQ(posix_spawn(&pid_, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ),
              0);
  }
  ~Started() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    std::filesystem::remove(err_);
  }
  // Waits (at most a minute) until stderr holds `text`; false if the process
  // ended first.
  bool waitFor(const std::string& text) {
    for (int i = 0; i < 600; ++i) {
      if (stderrText().find(text) != std::string::npos) return true;
      if (::waitpid(pid_, &status_, WNOHANG) == pid_) {
        pid_ = 0;
        return stderrText().find(text) != std::string::npos;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return false;
  }
  void signal(int number) const {
    if (pid_ > 0) ::kill(pid_, number);  // never 0: that would signal the test too
  }
  int wait() {
    if (pid_ > 0) ::waitpid(pid_, &status_, 0);
    pid_ = 0;
    return status_;
  }
  // True once the process has ended (wait() then gives its status), false
  // if it is still running after `most`.
  bool endsWithin(std::chrono::milliseconds most) {
    for (auto waited = std::chrono::milliseconds(0); pid_ > 0 && waited < most;
         waited += std::chrono::milliseconds(100)) {
      if (::waitpid(pid_, &status_, WNOHANG) == pid_) {
        pid_ = 0;
        return true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return pid_ == 0;
  }
  std::string stderrText() const { return fileText(err_); }

 private:
  std::filesystem::path err_;
  pid_t pid_ = 0;
  int status_ = 0;
};

}  // namespace overlap::testing
