// `overlap run`'s frame options as a user runs them: --threads N (the
// process never has more than N threads of its own: main, oneTBB's workers,
// cpubf's search, the renderer, counted in /proc/<pid>/task while it runs;
// the CUDA driver's threads, on a machine with a device, are not the run's:
// docs/DESIGN.md, "Threads") and --task-load X (the tasks sized from the
// scene, recorded).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "gpu/pair_finder.h"
#include "tests/scratch_path.h"

extern char** environ;

namespace {

std::size_t threadsIn(const std::filesystem::path& tasks) {
  std::error_code error;
  std::size_t count = 0;
  for (auto it = std::filesystem::directory_iterator(tasks, error);
       !error && it != std::filesystem::directory_iterator(); it.increment(error)) {
    ++count;
  }
  return count;
}

// The threads the CUDA driver starts in a process that asks for the device
// as every `overlap run` does (machineInfo(): is there one, and its name),
// counted here by asking the same in this process: 0 without a device.
// Asked once, before this process has any other thread to confuse the count.
std::size_t threadsTheCudaDriverStarts() {
  static const std::size_t driver_threads = [] {
    const std::size_t before = threadsIn("/proc/self/task");
    std::string why;
    if (overlap::finders::cudaDeviceAvailable(&why)) (void)overlap::finders::cudaDeviceName();
    const std::size_t after = threadsIn("/proc/self/task");
    return after > before ? after - before : 0;
  }();
  return driver_threads;
}

// Runs overlap with `args`, polling its thread count until it exits.
// Returns {exit status, most threads seen}.
std::pair<int, std::size_t> runCountingThreads(std::vector<std::string> args) {
  args.insert(args.begin(), OVERLAP_BINARY);
  std::vector<char*> argv;
  for (std::string& arg : args) argv.push_back(arg.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t files;
  posix_spawn_file_actions_init(&files);
  posix_spawn_file_actions_addopen(&files, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&files, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, argv[0], &files, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&files);
  if (spawned != 0) return {-1, 0};
  const std::filesystem::path tasks = "/proc/" + std::to_string(pid) + "/task";
  std::size_t most = 0;
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) == 0) {
    most = std::max(most, threadsIn(tasks));
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, most};
}

// The run's own threads are at most N; the CUDA driver's, where there is a
// device, come on top (0 here without one, so every thread is the run's).
TEST(ThreadCap, RunWithThreadsNeverHasMoreThreadsThanThat) {
  const std::size_t driver = threadsTheCudaDriverStarts();
  const std::filesystem::path out = overlap::testing::scratchPath("thread_cap_test");
  for (const int threads : {1, 2}) {
    std::filesystem::remove_all(out);
    // cpubf searching, the tasks beside the step, and pictures (OSMesa).
    const auto [status, most] =
        runCountingThreads({"run", "--scene", "4", "--objects", "300", "--frames", "30", "--algo",
                            "cpubf", "--threads", std::to_string(threads), "--capture-every", "10",
                            "--capture-size", "160x120", "--out", out.string()});
    EXPECT_EQ(status, 0) << "--threads " << threads;
    EXPECT_GE(most, 1u);
    EXPECT_LE(most, static_cast<std::size_t>(threads) + driver)
        << "--threads " << threads << ", the CUDA driver's threads " << driver;
  }
  std::filesystem::remove_all(out);
}

TEST(TaskLoad, SizesTheTasksFromTheSceneAndRecordsIt) {
  const std::filesystem::path out = overlap::testing::scratchPath("task_load_test");
  std::filesystem::remove_all(out);
  for (const char* load : {"0", "1"}) {
    const auto [status, threads] =
        runCountingThreads({"run", "--scene", "4", "--objects", "100", "--frames", "4", "--algo",
                            "cpubf", "--task-load", load, "--out", out.string()});
    ASSERT_EQ(status, 0) << "--task-load " << load;
    std::ifstream in(out / "summary.json");
    const nlohmann::json summary = nlohmann::json::parse(in);
    const nlohmann::json& parameters = summary["parameters"];
    const nlohmann::json& calibration = parameters["task_load_calibration"];
    EXPECT_EQ(calibration["physics_frames"], 4);
    EXPECT_GT(calibration["physics_ms"].get<double>(), 0.0);
    EXPECT_EQ(parameters["voices"], calibration["voices"]);
    EXPECT_EQ(parameters["agents"], calibration["agents"]);
    if (std::string(load) == "0") {
      EXPECT_EQ(parameters["voices"], 0);
      EXPECT_EQ(parameters["agents"], 0);
    } else {
      EXPECT_GT(parameters["voices"].get<int>(), 0);
      EXPECT_GT(parameters["agents"].get<int>(), 0);
    }
  }
  // The knob sizes the tasks itself: off, or sized by hand, is a usage error.
  for (const char* conflicting : {"--no-tasks", "--agents=5", "--voices=5"}) {
    EXPECT_EQ(
        runCountingThreads({"run", "--task-load", "1", conflicting, "--out", out.string()}).first,
        2)
        << conflicting;
  }
  std::filesystem::remove_all(out);
}

}  // namespace
