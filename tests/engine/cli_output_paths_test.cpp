// Where outputs land and what is said about them (docs/CLI.md, "Outputs"):
// names compared by where the kernel puts them (links followed by "..",
// chains, dangling links), the benchmark's prefix and stream cache, the
// line naming what was written, and the numbers every option reads alike.
// Each test makes the mess a hostile probe found and checks what a careful
// user expects.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "gpu/base/output_file.h"
#include "tests/engine/cli_test_support.h"

namespace {

using namespace overlap::testing;
namespace fs = std::filesystem;

class OutputPathsCliTest : public CliTest {
 protected:
  void SetUp() override {
    CliTest::SetUp();
    fs::create_directories(out_);
  }
  // `overlap ARGS` run from inside the test's folder (relative names).
  Result runHere(const std::string& args) {
    return runCommand("cd " + out_.string() + " && " + OVERLAP_BINARY + " " + args);
  }
};

// Only the entries `folder` holds, sorted.
std::vector<std::string> entriesOf(const fs::path& folder) {
  std::vector<std::string> names;
  for (const auto& entry : fs::recursive_directory_iterator(folder)) {
    names.push_back(fs::relative(entry.path(), folder).string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

// A --wav that reaches one of the run's files through a link and "..":
// the kernel goes to the parent of the link's target, and so does the
// check, however the link is reached (one link, "./" between, a chain).
TEST_F(OutputPathsCliTest, AWavThroughALinkAndDotDotIsTheFileTheKernelReaches) {
  fs::create_directories(out_ / "res" / "sub");
  fs::create_directory_symlink("res/sub", out_ / "link");
  fs::create_directory_symlink("link", out_ / "chain");
  fs::create_directory_symlink(out_ / "res" / "sub", out_ / "absolute");
  for (const std::string wav : {"link/../frames.csv", "link/./../frames.csv", "chain/../frames.csv",
                                "absolute/../summary.json", "link/../sub/../timeline.json"}) {
    const std::string args = "run --objects 30 --frames 4 --capture-every 0 --out res --wav " + wav;
    const Result result = runHere(args);
    EXPECT_EQ(result.exit_code, 2) << args << ": " << result.stderr_text;
    EXPECT_NE(result.stderr_text.find("is also an output of this run"), std::string::npos)
        << args << ": " << result.stderr_text;
    EXPECT_EQ(entriesOf(out_ / "res"), std::vector<std::string>{"sub"}) << args;
  }
}

// A --wav through a link into the run folder that names its PNGs' folder
// is refused before any frame; no manifest lists files that were never
// written.
TEST_F(OutputPathsCliTest, AWavThatIsThePngFolderThroughALinkIsRefusedBeforeAnyWork) {
  fs::create_directories(out_ / "d3" / "a");
  fs::create_directory_symlink("d3/a", out_ / "l3");
  const std::string args = "run --objects 30 --frames 4 --out d3 --wav l3/../frames";
  const Result result = runHere(args);
  EXPECT_EQ(result.exit_code, 2) << result.stderr_text;
  EXPECT_NE(result.stderr_text.find("is the folder of another output of this run"),
            std::string::npos)
      << result.stderr_text;
  EXPECT_EQ(entriesOf(out_ / "d3"), std::vector<std::string>{"a"});
}

// A name that reaches the run folder through a link is the run's output
// there (listed, published with the rest); a dangling link is refused.
TEST_F(OutputPathsCliTest, AWavReachedThroughALinkLandsWhereTheKernelPutsIt) {
  fs::create_directories(out_ / "res" / "sub");
  fs::create_directory_symlink("res/sub", out_ / "link");
  Result result =
      runHere("run --objects 30 --frames 3 --capture-every 0 --out res --wav link/../mix.wav");
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  EXPECT_TRUE(fs::is_regular_file(out_ / "res" / "mix.wav"));
  EXPECT_NE(fileText(out_ / "res" / overlap::OutputFolder::kManifestName).find("\nmix.wav\n"),
            std::string::npos);

  fs::create_directory_symlink("nowhere/x", out_ / "dangling");
  result =
      runHere("run --objects 30 --frames 3 --capture-every 0 --out r2 --wav dangling/../x.wav");
  EXPECT_EQ(result.exit_code, 2) << result.stderr_text;
  EXPECT_FALSE(fs::exists(out_ / "r2"));
  EXPECT_FALSE(fs::exists(out_ / "nowhere"));
}

// A link inside the run folder is still refused as named, whatever the
// spelling that reaches it.
TEST_F(OutputPathsCliTest, ALinkedPngFolderIsRefusedHoweverTheRunFolderIsNamed) {
  fs::create_directories(out_ / "photos");
  fs::create_directories(out_ / "shared");
  fs::create_directory_symlink("../photos", out_ / "shared" / "frames");
  fs::create_directory_symlink("shared", out_ / "alias");
  for (const std::string out : {"shared", "./shared", "alias", "photos/../shared"}) {
    const std::string args =
        "run --objects 20 --frames 2 --capture-every 1 --capture-size 32x24 --no-wav --out " + out;
    const Result result = runHere(args);
    EXPECT_EQ(result.exit_code, 2) << args << ": " << result.stderr_text;
    EXPECT_NE(result.stderr_text.find("frames is a symbolic link"), std::string::npos)
        << args << ": " << result.stderr_text;
    EXPECT_TRUE(fs::is_empty(out_ / "photos")) << args;
  }
}

// The benchmark's --out names a prefix of files: a device, FIFO, folder or
// open descriptor there is refused (its files would be made beside it, in
// /dev or /proc), whatever the descriptor is (here a regular file).
TEST_F(OutputPathsCliTest, TheBenchmarksOutCannotBeADeviceOrAFolder) {
  ASSERT_EQ(::mkfifo((out_ / "fifo").c_str(), 0600), 0);
  fs::create_directory(out_ / "folder");
  for (const std::string out : {std::string("/dev/null"), (out_ / "fifo").string(),
                                (out_ / "folder").string(), std::string("/dev/fd/5")}) {
    const std::string args =
        " --objects 30 --big-objects 0 --algos bvh --record-frames 2 "
        "--warmup 1 --repeats 1 --streams " +
        (out_ / "streams").string() + " --out " + out + " 5> " + (out_ / "fd5.txt").string();
    const Result result = runCommand(std::string(OVERLAP_BENCH_BINARY) + args);
    EXPECT_EQ(result.exit_code, 2) << args << ": " << result.stderr_text;
    EXPECT_NE(result.stderr_text.find("not a prefix of files"), std::string::npos)
        << result.stderr_text;
    EXPECT_FALSE(fs::exists(out + ".csv")) << out;
    EXPECT_FALSE(fs::exists(out_ / "streams")) << out;
  }
}

// A link planted at a stream's name in the benchmark's cache is replaced by
// the stream, never written through.
TEST_F(OutputPathsCliTest, TheBenchmarksStreamCacheNeverWritesThroughALink) {
  fs::create_directories(out_ / "streams");
  const fs::path cached = out_ / "streams" / "scene4_seed42_n30_f2.aabbs";
  fs::create_symlink("../victim.aabbs", cached);
  const Result result = runCommand(std::string(OVERLAP_BENCH_BINARY) +
                                   " --objects 30 --big-objects 0 --record-frames 2 --warmup 1 "
                                   "--record-only --streams " +
                                   (out_ / "streams").string());
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  EXPECT_FALSE(fs::exists(fs::symlink_status(out_ / "victim.aabbs")));
  EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(cached)));
}

// A name may hold any bytes: the JSON outputs write one that is not UTF-8
// as U+FFFD instead of failing once everything was measured.
TEST_F(OutputPathsCliTest, ANameThatIsNotUtf8IsWrittenIntoTheJsonOutputs) {
  const std::string name = "b\xff";
  const Result bench = runCommand(std::string(OVERLAP_BENCH_BINARY) +
                                  " --objects 30 --big-objects 0 --algos bvh --record-frames 2 "
                                  "--warmup 1 --repeats 1 --streams " +
                                  (out_ / name).string() + " --out " + (out_ / name).string());
  ASSERT_EQ(bench.exit_code, 0) << bench.stderr_text;
  EXPECT_TRUE(fs::is_regular_file(out_ / (name + ".json")));
  EXPECT_TRUE(fs::is_regular_file(out_ / (name + ".csv")));
  const Result run = runHere("run --objects 20 --frames 2 --capture-every 0 --out '" +
                             (out_ / ("r" + name)).string() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
  EXPECT_TRUE(fs::is_regular_file(out_ / ("r" + name) / "summary.json"));
  EXPECT_TRUE(fs::is_regular_file(out_ / ("r" + name) / "timeline.json"));
}

// `pairs` prints its rows on standard output and its summary on standard
// error: either one being its --input (`1<>FILE`, `>>FILE`, `2<>FILE`) would
// overwrite the stream as it is read; a FIFO that is both would never end.
TEST_F(OutputPathsCliTest, PairsRefusesAStandardOutputThatIsItsInput) {
  ASSERT_EQ(runHere("generate --objects 20 --frames 3 --out y.aabbs").exit_code, 0);
  const std::string before = fileText(out_ / "y.aabbs");
  // Standard error that is the input gets no message either: it would land there.
  for (const auto& [redirect, said] : std::vector<std::pair<std::string, std::string>>{
           {"1<>y.aabbs", "standard output is --input y.aabbs"},
           {">>y.aabbs", "standard output is --input y.aabbs"},
           {"2<>y.aabbs", ""},
           {"1<>y.aabbs 2<>y.aabbs", ""},
           {">>y.aabbs 2>&1", ""}}) {
    const Result result = runCommand("cd " + out_.string() + " && sh -c '" + OVERLAP_BINARY +
                                     " pairs --input y.aabbs " + redirect + "'");
    EXPECT_EQ(result.exit_code, 2) << redirect << ": " << result.stderr_text;
    EXPECT_NE(result.stderr_text.find(said), std::string::npos) << result.stderr_text;
    EXPECT_EQ(fileText(out_ / "y.aabbs"), before) << redirect;
  }
  // A FIFO read and written by the program would never end.
  ASSERT_EQ(::mkfifo((out_ / "p").c_str(), 0600), 0);
  const Result fifo =
      runCommand("cd " + out_.string() + " && (timeout 20 cat y.aabbs > p &) && sh -c '" +
                 "timeout 20 " + OVERLAP_BINARY + " pairs --input p 1<>p'");
  EXPECT_EQ(fifo.exit_code, 2) << fifo.stderr_text;
  EXPECT_EQ(runHere("pairs --input y.aabbs").exit_code, 0);
}

// The line naming what a command wrote escapes a newline in a name, as
// every message does: one line, whatever the name.
TEST_F(OutputPathsCliTest, TheWroteLineEscapesANewlineInAName) {
  const std::vector<std::pair<std::string, std::string>> commands = {
      {"run --objects 20 --frames 2 --capture-every 0 --out 'r\nx'", "overlap run: wrote r\\nx/"},
      {"record --objects 20 --frames 2 --out 's\nx.aabbs'", "overlap record: wrote s\\nx.aabbs"},
      {"capture --objects 20 --keyframes 1 --capture-size 32x24 --out 'c\nx'",
       "overlap capture: wrote 1 PNG in c\\nx"},
  };
  for (const auto& [args, wrote] : commands) {
    const Result result = runHere(args);
    ASSERT_EQ(result.exit_code, 0) << args << ": " << result.stderr_text;
    EXPECT_NE(result.stderr_text.find(wrote), std::string::npos) << result.stderr_text;
    for (const std::string raw : {"\nx/", "\nx.aabbs", "\nx (", "\nx\n"}) {
      EXPECT_EQ(result.stderr_text.find(raw), std::string::npos) << args << ": " << raw;
    }
  }
}

// --substeps K is read as every whole-number option reads a number.
TEST_F(OutputPathsCliTest, SubstepsRefusesWhatOtherWholeNumbersRefuse) {
  for (const std::string bad : {"010", "' 5'", "'5 '", "0x5", "0", "1001"}) {
    for (const std::string command :
         {"run --no-wav --capture-every 0 --out " + (out_ / "r").string(),
          "record --out " + (out_ / "s.aabbs").string()}) {
      const std::string args = command + " --objects 20 --frames 1 --substeps " + bad;
      const Result result = runOverlap(args);
      EXPECT_EQ(result.exit_code, 2) << args << ": " << result.stderr_text;
      EXPECT_NE(result.stderr_text.find("--substeps"), std::string::npos) << result.stderr_text;
    }
  }
  EXPECT_FALSE(fs::exists(out_ / "r"));
  EXPECT_EQ(
      runOverlap("record --objects 20 --frames 1 --substeps 5 --out " + (out_ / "s.aabbs").string())
          .exit_code,
      0);
}

// An edge ratio just past the bound reads as past it.
TEST_F(OutputPathsCliTest, TheEdgeRatioRefusedReadsAsOverTheBound) {
  const std::string args =
      "record --scene 4 --objects 20 --frames 1 --small-sizes 0.01 0.01 --average-sizes 0.01 "
      "0.01 --large-sizes 1.0000001 1.0000001 --out " +
      (out_ / "s.aabbs").string();
  const Result result = runOverlap(args);
  EXPECT_EQ(result.exit_code, 2) << result.stderr_text;
  EXPECT_NE(result.stderr_text.find("times the smallest edge"), std::string::npos)
      << result.stderr_text;
  EXPECT_EQ(result.stderr_text.find("is 100 times"), std::string::npos) << result.stderr_text;
}

// A ratio of exactly 100 in decimals is the bound, whatever doubles make of
// it (1.3 / 0.013 is 100.00000000000001 in them).
TEST_F(OutputPathsCliTest, AnEdgeRatioOfExactlyTheBoundIsAllowed) {
  const Result result = runOverlap(
      "record --scene 4 --objects 20 --frames 1 --small-sizes 0.013 0.013 --average-sizes 0.013 "
      "1.3 --large-sizes 1.3 1.3 --out " +
      (out_ / "s.aabbs").string());
  EXPECT_EQ(result.exit_code, 0) << result.stderr_text;
}

}  // namespace
