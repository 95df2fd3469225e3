// Boxes that leave the simulation inside a substep, through every command
// that steps a scene (run, record, latency, capture): at 1e6 m/s^2 times 100
// over 1 s frames, every value within its documented bounds, boxes reach
// AABBs too large for Bullet and leave after CCD made contacts for them.
// Each command must say so, finish with exit 0 and leave no temporary file;
// Bullet's sweep and prune alone stops instead, naming its cells (boxes
// 10^5 m away leave 16-bit sap's grid, and sap32's floats, coarser than the
// boxes), exit 1, nothing half-written.
#include <gtest/gtest.h>

#include <filesystem>
#include <regex>
#include <string>
#include <utility>

#include "tests/engine/cli_test_support.h"

namespace {

using namespace overlap::testing;
namespace fs = std::filesystem;

const std::string kLeavingScene =
    "--scene 1 --objects 50 --gravity 1e6 --gravity-scale 100 --frame-time 1";
const std::string kFrames = " --frames 3";  // capture runs to its last keyframe instead

// The broadphases that step the leaving scene to its end; gpubf and
// gpubf-paper run cpusap without a device, and run emulated in the CUDA
// emulation build.
const char* const kAlgorithms[] = {"bf", "bvh", "cpubf", "cpusap", "gpubf", "gpubf-paper"};

class BoxRemovalCliTest : public CliTest {
 protected:
  // Runs `overlap ARGS`: exit 0, the message that boxes left, nothing half-written.
  void expectBoxesLeaveAndTheRunEnds(const std::string& args) {
    SCOPED_TRACE(args);
    const Result result = runOverlap(args);
    ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
    EXPECT_NE(result.stderr_text.find("left the simulation"), std::string::npos)
        << result.stderr_text;
    EXPECT_NE(result.stderr_text.find("AABB too large for Bullet"), std::string::npos)
        << result.stderr_text;
    expectNoTemporaries();
  }

  // Runs `overlap ARGS` with 16-bit sap, then with sap32 for it: exit 1,
  // the cells named with the broadphases to use instead, no temporary left.
  void expectSapStopsNamingItsGrid(const std::string& args) {
    for (const auto& [algorithm, reason] :
         {std::pair{"sap", "16-bit grid"}, std::pair{"sap32", "floats' precision"}}) {
      const std::string with = std::regex_replace(args, std::regex(" --algo sap\\b"),
                                                  std::string(" --algo ") + algorithm);
      SCOPED_TRACE(with);
      const Result result = runOverlap(with);
      EXPECT_EQ(result.exit_code, 1) << result.stderr_text;
      EXPECT_NE(result.stderr_text.find(reason), std::string::npos) << result.stderr_text;
      EXPECT_NE(result.stderr_text.find("use "), std::string::npos) << result.stderr_text;
      expectNoTemporaries();
    }
  }

  // A temporary is an output's name with ".overlap-" and a suffix after it
  // (the run's manifest, ".overlap-outputs", is no temporary).
  static bool isTemporary(const fs::path& path) {
    return path.filename().string().find(".overlap-", 1) != std::string::npos;
  }

  // No temporary of the output is left: none in the output folder, or for a
  // file none beside it carrying its name.
  void expectNoTemporaries() const {
    if (fs::is_directory(out_)) {
      for (const fs::directory_entry& entry : fs::recursive_directory_iterator(out_)) {
        EXPECT_FALSE(isTemporary(entry.path())) << "left behind: " << entry.path();
      }
      return;
    }
    const std::string own = out_.filename().string();
    for (const fs::directory_entry& entry : fs::directory_iterator(out_.parent_path())) {
      if (entry.path().filename().string().find(own) == std::string::npos) continue;
      EXPECT_FALSE(isTemporary(entry.path())) << "left behind: " << entry.path();
    }
  }
};

TEST_F(BoxRemovalCliTest, RunWithEveryBroadphase) {
  for (const char* algorithm : kAlgorithms) {
    expectBoxesLeaveAndTheRunEnds("run " + kLeavingScene + kFrames + " --algo " + algorithm +
                                  " --no-tasks --capture-every 0 --out " + out_.string());
    EXPECT_TRUE(fs::exists(out_ / "summary.json")) << algorithm;
  }
  expectSapStopsNamingItsGrid("run " + kLeavingScene + kFrames +
                              " --algo sap --no-tasks --capture-every 0 --out " + out_.string());
}

TEST_F(BoxRemovalCliTest, RunWithTheTasksTheBulletSolverAndCcdOnEveryBox) {
  expectBoxesLeaveAndTheRunEnds("run " + kLeavingScene + kFrames +
                                " --algo bvh --capture-every 0 --out " + out_.string());
  EXPECT_TRUE(fs::exists(out_ / "sound.wav"));
  expectBoxesLeaveAndTheRunEnds("run " + kLeavingScene + kFrames +
                                " --algo cpusap --solver bullet --ccd all --no-tasks "
                                "--capture-every 0 --out " +
                                out_.string());
}

TEST_F(BoxRemovalCliTest, Record) {
  out_ += ".aabbs";
  expectBoxesLeaveAndTheRunEnds("record " + kLeavingScene + kFrames + " --out " + out_.string());
  expectBoxesLeaveAndTheRunEnds("record " + kLeavingScene + kFrames +
                                " --ccd all --solver bullet --out " + out_.string());
  EXPECT_TRUE(fs::exists(out_));
  fs::remove(out_);
}

TEST_F(BoxRemovalCliTest, LatencyWithEveryBroadphase) {
  std::string algorithms;
  for (const char* algorithm : kAlgorithms) {
    algorithms += (algorithms.empty() ? "" : ",") + std::string(algorithm);
  }
  expectBoxesLeaveAndTheRunEnds("latency " + kLeavingScene + kFrames + " --algo " + algorithms);
  expectBoxesLeaveAndTheRunEnds("latency " + kLeavingScene + kFrames +
                                " --algo cpusap --ccd all --solver bullet");
  expectSapStopsNamingItsGrid("latency " + kLeavingScene + kFrames + " --algo sap");
}

TEST_F(BoxRemovalCliTest, Capture) {
  expectBoxesLeaveAndTheRunEnds("capture " + kLeavingScene +
                                " --algo bvh --keyframes 0,2 --capture-size 32x24 --out " +
                                out_.string());
  EXPECT_TRUE(fs::exists(out_ / "scene1_frame0002.png"));
}

}  // namespace
