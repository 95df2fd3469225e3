// A hostile probe's table, row by row (the command line's rows; docs/CLI.md
// has the promises): each test makes the mess a row describes and checks
// what a careful user expects.  The streams are written here, as bytes:
// "line N" is box i = (0.5i, 0, 0)-(0.5i + 1, 1, 1) in every frame.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdint>
#include <cstring>
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

// One box as the .aabbs layout stores it: min x, y, z, 0, max x, y, z, 0.
struct Box {
  float min[3];
  float max[3];
};

void appendFloats(std::string& bytes, const float (&xyz)[3]) {
  const float four[4] = {xyz[0], xyz[1], xyz[2], 0.0f};
  bytes.append(reinterpret_cast<const char*>(four), sizeof(four));
}

// A stream of `frames.size()` stored frames, each a list of boxes.
void writeStream(const fs::path& path, const std::vector<std::vector<Box>>& frames) {
  std::string bytes(256, '\0');
  bytes.replace(0, 4, "test");
  const std::int32_t counts[4] = {static_cast<std::int32_t>(frames.front().size()),
                                  static_cast<std::int32_t>(frames.size() - 1), 0, 0};
  bytes.append(reinterpret_cast<const char*>(counts), sizeof(counts));
  appendFloats(bytes, {-1, -1, -1});
  appendFloats(bytes, {1e5f, 2, 2});
  for (const auto& frame : frames) {
    for (const Box& box : frame) {
      appendFloats(bytes, box.min);
      appendFloats(bytes, box.max);
    }
  }
  std::ofstream(path, std::ios::binary) << bytes;
}

std::vector<Box> line(int n) {
  std::vector<Box> boxes;
  for (int i = 0; i < n; ++i) {
    const float x = 0.5f * static_cast<float>(i);
    boxes.push_back({{x, 0, 0}, {x + 1, 1, 1}});
  }
  return boxes;
}

fs::path writeLine(const fs::path& path, int n, int stored_frames) {
  writeStream(path,
              std::vector<std::vector<Box>>(static_cast<std::size_t>(stored_frames), line(n)));
  return path;
}

// Runs the benchmark with `args`, capturing stderr.
Result runBench(const std::string& args) {
  return runCommand(std::string(OVERLAP_BENCH_BINARY) + " " + args);
}

// The fields of one CSV line, as RFC 4180 reads them.
std::vector<std::string> csvFields(const std::string& text) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted && c == '"' && i + 1 < text.size() && text[i + 1] == '"') {
      fields.back() += '"';
      ++i;
    } else if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  return fields;
}

// The lines of a CSV file that are neither comments nor the header.
std::vector<std::string> csvRows(const std::string& text) {
  std::vector<std::string> rows;
  std::size_t start = 0;
  bool header = true;
  for (std::size_t end = text.find('\n'); end != std::string::npos;
       start = end + 1, end = text.find('\n', start)) {
    const std::string row = text.substr(start, end - start);
    if (row.empty() || row[0] == '#') continue;
    if (!header) rows.push_back(row);
    header = false;
  }
  return rows;
}

void expectRefused(const Result& result, const std::string& args, const std::string& message) {
  EXPECT_EQ(result.exit_code, 2) << args << ": " << result.stderr_text;
  EXPECT_EQ(lineCount(result.stderr_text), 1) << args << ": " << result.stderr_text;
  EXPECT_NE(result.stderr_text.find(message), std::string::npos)
      << args << ": " << result.stderr_text;
}

class ProbeCliTest : public CliTest {
 protected:
  void SetUp() override {
    CliTest::SetUp();
    fs::create_directories(out_);
  }
  // `overlap run` of a few boxes into `folder`, with `args`.
  Result smallRun(const fs::path& folder, const std::string& args) {
    return runOverlap("run --objects 20 --frames 2 --capture-every 0 --out " + folder.string() +
                      " " + args);
  }
};

// A name with a newline or a leading '#' is one name of the
// manifest, removed by the next run that does not write it; a user's file
// is never removed.
TEST_F(ProbeCliTest, NamesWithNewlinesOrHashesCannotMisleadTheManifest) {
  const fs::path res = out_ / "res";
  fs::create_directories(res);
  std::ofstream(res / "notes") << "data";
  const std::string newline_name = "\"$(printf '" + (res / "notes").string() + "\\nx.wav')\"";
  ASSERT_EQ(smallRun(res, "--wav " + newline_name).exit_code, 0);
  EXPECT_TRUE(fs::exists(res / "notes\nx.wav"));
  ASSERT_EQ(smallRun(res, "--wav '" + (res / "#a.wav").string() + "'").exit_code, 0);
  EXPECT_FALSE(fs::exists(res / "notes\nx.wav"));
  EXPECT_TRUE(fs::exists(res / "#a.wav"));
  ASSERT_EQ(smallRun(res, "--no-wav").exit_code, 0);
  EXPECT_FALSE(fs::exists(res / "#a.wav"));
  EXPECT_EQ(fileText(res / "notes"), "data");
}

// The benchmark's --out names a file prefix; a folder is refused
// before any work and nothing is written.
TEST_F(ProbeCliTest, TheBenchmarksOutMustNameAFile) {
  const fs::path stream = writeLine(out_ / "s.aabbs", 10, 2);
  fs::create_directories(out_ / "work");
  for (const char* bad : {"\"\"", ".", "sub/", "/", "..", "sub/."}) {
    const std::string args =
        "--input " + stream.string() + " --algos bf --warmup 0 --repeats 1 --out " + bad;
    const Result result =
        runCommand("cd " + (out_ / "work").string() + " && " + OVERLAP_BENCH_BINARY + " " + args);
    expectRefused(result, args, "--out");
    EXPECT_TRUE(fs::is_empty(out_ / "work")) << args;
  }
  EXPECT_FALSE(fs::exists("/.csv"));
}

// Outputs checked before any work, creating nothing; a legal name
// whose temporary would be too long is written.
TEST_F(ProbeCliTest, OutputsAreCheckedBeforeAnyWorkAndLegalNamesWritten) {
  const fs::path long_name = out_ / (std::string(245, 'r') + ".aabbs");
  const Result written = runOverlap("record --objects 20 --frames 2 --out " + long_name.string());
  EXPECT_EQ(written.exit_code, 0) << written.stderr_text;
  EXPECT_TRUE(fs::exists(long_name));

  fs::create_symlink("loop", out_ / "loop");
  fs::create_directories(out_ / "bd2.csv");
  const std::string stream = writeLine(out_ / "s.aabbs", 10, 2).string();
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"record --objects 20 --frames 2 --out " + (out_ / "newdir").string() + "/.",
       "names a folder"},
      {"record --objects 20 --frames 2 --out " + (out_ / "loop").string(), "symbolic links"},
      {"record --objects 20 --frames 2 --out " + (out_ / std::string(256, 'r')).string(),
       "is longer than 255 bytes"},
      {"run --objects 20 --frames 2 --out " + (out_ / "newdir" / "run").string() + " --wav " +
           (out_ / "newdir" / "w").string() + "/",
       "--wav"},
      {"run --objects 20 --frames 2 --capture-size 010x010 --out " +
           (out_ / "newdir" / "run").string(),
       "--capture-size"},
  };
  for (const auto& [args, message] : bad) expectRefused(runOverlap(args), args, message);
  const std::string bench =
      "--input " + stream + " --algos bf --warmup 0 --repeats 1 --out " + (out_ / "bd2").string();
  expectRefused(runBench(bench), bench, "bd2.csv: is a directory");
  EXPECT_FALSE(fs::exists(out_ / "newdir"));
  EXPECT_FALSE(fs::exists(out_ / "bd2.json"));
}

// Every --input is checked (header, size, boxes, frames against
// --warmup, boxes against the algorithms) before the first is measured.
TEST_F(ProbeCliTest, EveryBenchmarkInputIsCheckedBeforeTheFirstIsMeasured) {
  const std::string good = writeLine(out_ / "good.aabbs", 10, 3).string();
  std::vector<std::vector<Box>> frames(3, line(10));
  frames[2][4].min[0] = 1e30f;  // min above max
  writeStream(out_ / "bad.aabbs", frames);
  const std::string short_stream = writeLine(out_ / "short.aabbs", 10, 2).string();
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"--input " + good + " " + (out_ / "bad.aabbs").string() + " --warmup 0",
       "bad.aabbs: frame 2, object 4"},
      {"--input " + good + " " + short_stream + " --warmup 2", "--warmup 2"},
  };
  for (const auto& [inputs, message] : bad) {
    const std::string args = inputs + " --algos bf --repeats 1 --out " + (out_ / "result").string();
    const Result result = runBench(args);
    expectRefused(result, args, message);
    EXPECT_EQ(result.stderr_text.find("repeat"), std::string::npos) << result.stderr_text;
    EXPECT_FALSE(fs::exists(out_ / "result.csv"));
  }
}

// Two outputs of one run cannot be one file.
TEST_F(ProbeCliTest, TwoOutputsOfOneRunCannotShareAName) {
  const fs::path r2 = out_ / "r2";
  for (const char* name : {"summary.json", "frames.csv", ".overlap-outputs"}) {
    const std::string args = "--wav " + (r2 / name).string();
    const Result result = smallRun(r2, args);
    expectRefused(result, args,
                  "--wav " + (r2 / name).string() + ": is also an output of this run");
    EXPECT_FALSE(fs::exists(r2)) << name;
  }
}

// sap over Bullet's object limit is a bad input in `pairs`, as in
// `run` and the benchmark.
TEST_F(ProbeCliTest, SapOverBulletsObjectLimitExits2InPairs) {
  const std::string stream = writeLine(out_ / "line40k.aabbs", 40000, 2).string();
  const std::string args = "pairs --algo sap --input " + stream;
  expectRefused(runOverlap(args), args, "--algo sap: holds at most 32765 objects");
}

// The churn column holds the share given, exactly; a share that
// churns no box is refused.
TEST_F(ProbeCliTest, ChurnIsWrittenExactlyAndMustChurnABox) {
  const std::string stream = writeLine(out_ / "line.aabbs", 10000, 2).string();
  const std::string args = "--input " + stream +
                           " --algos cpusap --warmup 0 --repeats 1 --churn 0.0004,0.0001 --out " +
                           (out_ / "result").string();
  const Result result = runBench(args);
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  std::vector<std::string> churns;
  for (const std::string& row : csvRows(fileText(out_ / "result.csv"))) {
    churns.push_back(csvFields(row).at(12));
  }
  EXPECT_EQ(churns, (std::vector<std::string>{"0", "0.0004", "0.0001"}));

  const std::string tiny = "--input " + stream + " --algos cpusap --warmup 0 --churn 1e-300";
  expectRefused(runBench(tiny), tiny, "--churn 1e-300: churns no box");
}

// A stream's name with a comma or a newline stays one field of one
// row; the command comment stays one line.
TEST_F(ProbeCliTest, CsvFieldsWithCommasOrNewlinesAreQuoted) {
  const fs::path comma = writeLine(out_ / "n=300,line.aabbs", 30, 2);
  const fs::path newline = writeLine(out_ / "new\nline.aabbs", 30, 2);
  const std::string args = "--input '" + comma.string() + "' \"$(printf '" +
                           (out_ / "new").string() + "\\nline.aabbs')\" --algos bf --warmup 0 " +
                           "--repeats 1 --out " + (out_ / "result").string();
  const Result result = runBench(args);
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  const std::string csv = fileText(out_ / "result.csv");
  const std::vector<std::string> rows = csvRows(csv);
  // One row has a newline inside its quoted field: read as RFC 4180, the
  // file holds two rows, each with as many fields as the header.
  const std::size_t header_start = csv.find("\nn,algorithm,") + 1;
  const std::size_t columns =
      csvFields(csv.substr(header_start, csv.find('\n', header_start) - header_start)).size();
  std::string joined;
  for (const std::string& row : rows) joined += row + '\n';
  const std::vector<std::string> first = csvFields(rows.at(0));
  ASSERT_EQ(first.size(), columns) << csv;
  EXPECT_EQ(first[11], comma.string());
  const std::size_t second_start = joined.find('\n') + 1;
  const std::vector<std::string> second =
      csvFields(joined.substr(second_start, joined.size() - second_start - 1));
  ASSERT_EQ(second.size(), columns) << csv;
  EXPECT_EQ(second[11], newline.string());
  const std::string command_line = csv.substr(csv.find("command: "));
  EXPECT_NE(command_line.substr(0, command_line.find('\n')).find("\\x0a"), std::string::npos)
      << csv;
}

// Options a benchmark run would ignore are refused, naming both.
TEST_F(ProbeCliTest, OptionsTheBenchmarkWouldIgnoreAreRefused) {
  const std::string stream = writeLine(out_ / "s.aabbs", 10, 2).string();
  const std::string input = "--input " + stream + " --warmup 0 ";
  const std::vector<std::pair<std::string, std::string>> bad = {
      {input + "--objects 10", "--objects and --input"},
      {input + "--big-objects 10", "--big-objects and --input"},
      {input + "--streams " + out_.string(), "--streams and --input"},
      {input + "--record-frames 3", "--record-frames and --input"},
      {input + "--record-only", "--input and --record-only"},
      {input + "--stream-stats --grid-check", "--grid-check and --stream-stats"},
      {input + "--stream-stats --churn 0.1", "--churn and --stream-stats"},
  };
  for (const auto& [args, message] : bad) expectRefused(runBench(args), args, message);
}

// Every list refuses empty items, repeated items and leading zeros.
TEST_F(ProbeCliTest, ListsRefuseEmptyAndRepeatedItemsAndLeadingZeros) {
  const std::vector<std::pair<std::string, std::string>> overlap = {
      {"latency --objects 20 --frames 2 --growth 1,,2", "--growth: \"1,,2\" has an empty item"},
      {"latency --objects 20 --frames 2 --algo bvh,", "--algo: \"bvh,\" has an empty item"},
      {"latency --objects 20 --frames 2 --growth 0,0", "--growth: 0 is listed twice"},
      {"latency --objects 20 --frames 2 --growth 1,1.0", "--growth: 1.0 (1) is listed twice"},
      {"latency --objects 20 --frames 2 --growth 01", "--growth: 01 has a leading zero"},
      {"capture --objects 20 --keyframes 010", "--keyframes: 010 has a leading zero"},
      {"capture --objects 20 --keyframes 1,1", "--keyframes: 1 is listed twice"},
      {"capture --objects 20 --capture-size 010x010", "width \"010\" is not a positive integer"},
  };
  for (const auto& [args, message] : overlap) {
    expectRefused(runOverlap(args + " --out " + (out_ / "o").string()), args, message);
  }
  const std::vector<std::pair<std::string, std::string>> bench = {
      {"--algos bf,,cpusap", "--algos: \"bf,,cpusap\" has an empty item"},
      {"--churn 0.1,,0.2", "--churn: \"0.1,,0.2\" has an empty item"},
      {"--objects 60,,0", "--objects: \"60,,0\" has an empty item"},
      {"--objects 60,60", "--objects: 60 is listed twice"},
      {"--big-algos bvh,bvh", "--big-algos: bvh is listed twice"},
  };
  for (const auto& [args, message] : bench) expectRefused(runBench(args), args, message);
  EXPECT_FALSE(fs::exists(out_ / "o"));
}

// "Pairs changed per frame" of frames without pairs is no figure.
TEST_F(ProbeCliTest, PairsChangedWithoutPairsIsNotAFigure) {
  const std::vector<Box> touching = {{{0, 0, 0}, {1, 1, 1}}, {{0.5f, 0, 0}, {1.5f, 1, 1}}};
  const std::vector<Box> apart = {{{0, 0, 0}, {1, 1, 1}}, {{5, 0, 0}, {6, 1, 1}}};
  writeStream(out_ / "ex.aabbs", {touching, apart});
  int exit_code = -1;
  const std::string printed =
      shellStdout(std::string(OVERLAP_BENCH_BINARY) + " --input " + (out_ / "ex.aabbs").string() +
                      " --warmup 0 --stream-stats 2>/dev/null",
                  &exit_code);
  EXPECT_EQ(exit_code, 0);
  EXPECT_NE(printed.find("pairs changed per frame n/a"), std::string::npos) << printed;
}

// Counts of one are singular; a size too large says so.
TEST_F(ProbeCliTest, CountsOfOneAreSingularAndHugeSizesAreOutOfRange) {
  const Result record =
      runOverlap("record --objects 20 --frames 1 --out " + (out_ / "one.aabbs").string());
  EXPECT_NE(record.stderr_text.find("(20 objects, the start and 1 frame)"), std::string::npos)
      << record.stderr_text;
  const Result run = runOverlap(
      "run --objects 20 --frames 1 --capture-every 1 --capture-size "
      "32x24 --no-wav --out " +
      (out_ / "run").string());
  EXPECT_NE(run.stderr_text.find(", 1 PNG in "), std::string::npos) << run.stderr_text;
  const std::string huge = "capture --objects 20 --keyframes 0 --capture-size 4294967297x1 --out " +
                           (out_ / "shots").string();
  expectRefused(runOverlap(huge), huge, "width \"4294967297\" is out of range");
}

// Two outputs that are one file are refused before any work however the
// names are spelled, folders not made yet included.
TEST_F(ProbeCliTest, TwoOutputsThatAreOneFileAreRefusedHoweverSpelled) {
  const std::string absolute = (out_ / "r3").string();
  const std::vector<std::pair<std::string, std::string>> spellings = {
      {"./r3", "r3/summary.json"},     {"r3", "./r3/summary.json"},
      {"r3", "r3//frames.csv"},        {"r3", absolute + "/timeline.json"},
      {"r3/../r3", "r3/summary.json"}, {"./r3/", "r3/new/../.overlap-outputs"},
  };
  for (const auto& [out, wav] : spellings) {
    const std::string args =
        "run --objects 20 --frames 2 --capture-every 0 --out " + out + " --wav " + wav;
    const Result result = runCommand("cd " + out_.string() + " && " + OVERLAP_BINARY + " " + args);
    expectRefused(result, args, "is also an output of this run");
    EXPECT_FALSE(fs::exists(out_ / "r3")) << args;
  }
}

// A --wav that is the run's folder, a folder above it, or the folder of its
// PNGs is refused before any work, creating nothing.
TEST_F(ProbeCliTest, AWavThatIsAFolderOfTheRunIsRefusedBeforeAnyWork) {
  const std::string rf = (out_ / "a" / "rf").string();
  const std::vector<std::string> wavs = {rf, (out_ / "a").string(), rf + "/frames"};
  for (const std::string& wav : wavs) {
    const std::string args =
        "run --objects 20 --frames 2 --capture-every 1 --capture-size 32x24 "
        "--out " +
        rf + " --wav " + wav;
    const Result result = runOverlap(args);
    expectRefused(result, args, "--wav " + wav + ": is ");
    EXPECT_NE(result.stderr_text.find("not a file"), std::string::npos) << result.stderr_text;
    EXPECT_FALSE(fs::exists(out_ / "a")) << args;
  }
}

// A run folder someone else prepared cannot make a run remove or overwrite
// anything outside it: no link is followed for the manifest, for the
// outputs' own names, or for a folder holding an entry to remove.
TEST_F(ProbeCliTest, ARunFolderNeverReachesOutsideItselfThroughALink) {
  const fs::path photos = out_ / "photos";
  const fs::path shared = out_ / "shared";
  fs::create_directories(photos);
  fs::create_directories(shared);
  std::ofstream(photos / "IMG_0001.jpg") << "photo";
  std::ofstream(photos / "precious.json") << "precious";
  std::ofstream(out_ / "list") << overlap::OutputFolder::kManifestHeader << "\nkeep.txt\n";
  std::ofstream(shared / "keep.txt") << "mine";
  fs::create_directory_symlink("../photos", shared / "frames");
  fs::create_symlink("../photos/precious.json", shared / "summary.json");
  fs::create_symlink("../list", shared / ".overlap-outputs");

  ASSERT_EQ(smallRun(shared, "--no-wav").exit_code, 0);
  EXPECT_EQ(fileText(shared / "keep.txt"), "mine");  // the linked manifest listed nothing
  std::ofstream(shared / ".overlap-outputs")
      << overlap::OutputFolder::kManifestHeader << "\nframes/IMG_0001.jpg\n";
  ASSERT_EQ(smallRun(shared, "--no-wav").exit_code, 0);
  EXPECT_EQ(fileText(photos / "IMG_0001.jpg"), "photo");
  EXPECT_EQ(fileText(photos / "precious.json"), "precious");
  EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(shared / "summary.json")));
  EXPECT_EQ(fileText(out_ / "list").find("summary.json"), std::string::npos);

  const std::string args =
      "run --objects 20 --frames 2 --capture-every 1 --capture-size 32x24 "
      "--no-wav --out " +
      shared.string();
  expectRefused(runOverlap(args), args, "frames is a symbolic link");
  EXPECT_EQ(std::distance(fs::directory_iterator(photos), fs::directory_iterator()), 2);

  // A list that is a FIFO would hang the run's end: refused before any work.
  fs::remove(shared / ".overlap-outputs");
  ASSERT_EQ(::mkfifo((shared / ".overlap-outputs").c_str(), 0600), 0);
  expectRefused(smallRun(shared, "--no-wav"), "a FIFO list", "is not a regular file");
}

// /dev/stdout as an output works when standard output is a pipe.
TEST_F(ProbeCliTest, DevStdoutOnAPipeIsWrittenThrough) {
  int exit_code = -1;
  const std::string stream = shellStdout(
      std::string(OVERLAP_BINARY) + " record --objects 20 --frames 2 --out /dev/stdout 2>/dev/null",
      &exit_code);
  EXPECT_EQ(exit_code, 0);
  EXPECT_EQ(stream.size(), 304u + 3u * 20u * 32u);  // the header, then 3 frames of 20 boxes
  const std::string wav = shellStdout(std::string(OVERLAP_BINARY) +
                                          " run --objects 20 --frames 2 --capture-every 0 --out " +
                                          (out_ / "r").string() + " --wav /dev/stdout 2>/dev/null",
                                      &exit_code);
  EXPECT_EQ(exit_code, 0);
  EXPECT_EQ(wav.substr(0, 4), "RIFF");
}

// A write past `ulimit -f` is reported naming the file (exit 1), not a
// silent SIGXFSZ, and leaves no temporary and no new folder.
TEST_F(ProbeCliTest, AFileOverTheSizeLimitIsReportedNamingIt) {
  const std::vector<std::pair<std::string, std::string>> runs = {
      {"record --objects 2000 --frames 5 --out " + (out_ / "new" / "r.aabbs").string(), "r.aabbs"},
      {"run --objects 20 --frames 30 --capture-every 0 --out " + (out_ / "new" / "run").string(),
       "sound.wav"},
  };
  for (const auto& [args, file] : runs) {
    const Result result = runCommand("ulimit -f 8 && " + std::string(OVERLAP_BINARY) + " " + args);
    EXPECT_EQ(result.exit_code, 1) << args << ": " << result.stderr_text;
    EXPECT_NE(result.stderr_text.find(file + ": cannot write: File too large"), std::string::npos)
        << result.stderr_text;
    EXPECT_FALSE(fs::exists(out_ / "new")) << args;
  }
}

// Whatever a program prints on standard output, a failed write there exits
// 1 naming it: help, version, the algorithm list, the stream figures.
TEST_F(ProbeCliTest, StandardOutputThatCannotBeWrittenExits1) {
  const std::string stream = writeLine(out_ / "s.aabbs", 10, 2).string();
  const std::vector<std::string> commands = {
      std::string(OVERLAP_BINARY) + " --help",
      std::string(OVERLAP_BINARY) + " --version",
      std::string(OVERLAP_BINARY) + " run --help",
      std::string(OVERLAP_BINARY) + " --list-algos --json",
      std::string(OVERLAP_BENCH_BINARY) + " --help",
      std::string(OVERLAP_BENCH_BINARY) + " --input " + stream + " --warmup 0 --stream-stats",
  };
  for (const std::string& command : commands) {
    const Result result = runCommand("{ " + command + " > /dev/full; }");
    EXPECT_EQ(result.exit_code, 1) << command << ": " << result.stderr_text;
    EXPECT_NE(result.stderr_text.find("standard output: cannot write"), std::string::npos)
        << command << ": " << result.stderr_text;
  }
}

// The benchmark checks that the streams it must record fit in --streams
// before recording the first.
TEST_F(ProbeCliTest, TheBenchmarkRefusesStreamsItsDiskCannotHoldBeforeRecording) {
  const std::string args =
      "--objects 10000000 --big-objects 0 --record-frames 100000 --algos "
      "cpusap --warmup 0 --repeats 1 --streams " +
      (out_ / "new" / "streams").string() + " --out " + (out_ / "b").string();
  expectRefused(runBench(args), args, "--streams");
  EXPECT_FALSE(fs::exists(out_ / "new"));
}

// A value holding a newline stays on the error's one line, escaped.
TEST_F(ProbeCliTest, AnErrorMessageStaysOnOneLine) {
  const std::string args = "run --objects \"$(printf '5\\nx')\" --out " + (out_ / "r").string();
  expectRefused(runOverlap(args), args, "5\\nx");
}

// An option given twice says so in plain words.
TEST_F(ProbeCliTest, AnOptionGivenTwiceSaysSo) {
  const std::string args = "run --objects 5 --objects 6 --out " + (out_ / "r").string();
  expectRefused(runOverlap(args), args, "--objects is given 2 times; give it once");
}

// The benchmark refuses a --seed nothing reads and a stream given twice,
// however reached.
TEST_F(ProbeCliTest, TheBenchmarkRefusesAnIgnoredSeedAndARepeatedInput) {
  const std::string stream = writeLine(out_ / "s.aabbs", 10, 2).string();
  const std::string tail = " --algos bf --warmup 0 --repeats 1 --out " + (out_ / "b").string();
  expectRefused(runBench("--input " + stream + " --seed 5" + tail), "--seed", "--seed and --input");
  expectRefused(runBench("--input " + stream + " " + (out_ / "." / "s.aabbs").string() + tail),
                "twice", "given twice");
  // A hard link is the same file too.
  fs::create_hard_link(stream, out_ / "hard.aabbs");
  expectRefused(runBench("--input " + stream + " " + (out_ / "hard.aabbs").string() + tail),
                "a hard link", "given twice");
  EXPECT_FALSE(fs::exists(out_ / "b.csv"));
}

// --list-algos takes nothing but --json.
TEST_F(ProbeCliTest, ListAlgosRefusesAnythingBesideIt) {
  expectRefused(runOverlap("--list-algos bogus"), "--list-algos bogus", "'bogus'");
}

// --stream-stats runs no finder, so it warns about none.
TEST_F(ProbeCliTest, StreamStatsWarnsAboutNoFinder) {
  const std::string stream = writeLine(out_ / "s.aabbs", 10, 2).string();
  const Result result = runBench("--input " + stream + " --warmup 0 --stream-stats");
  EXPECT_EQ(result.exit_code, 0) << result.stderr_text;
  EXPECT_EQ(result.stderr_text.find("gpu"), std::string::npos) << result.stderr_text;
}

// `record` checks the disk's room for the whole stream before any physics.
TEST_F(ProbeCliTest, RecordRefusesAStreamItsDiskCannotHoldBeforeAnyWork) {
  const std::string args =
      "record --objects 10000000 --frames 1000000 --out " + (out_ / "huge.aabbs").string();
  expectRefused(runOverlap(args), args, "its folder has");
  EXPECT_FALSE(fs::exists(out_ / "huge.aabbs"));
}

// A run's closing line names one PNG once, and the last run's files it
// removed.
TEST_F(ProbeCliTest, TheClosingLineNamesWhatWasWrittenAndRemoved) {
  const fs::path r = out_ / "r";
  const Result one = runOverlap(
      "run --objects 20 --frames 1 --capture-every 1 --capture-size 32x24 --out " + r.string());
  ASSERT_EQ(one.exit_code, 0) << one.stderr_text;
  EXPECT_NE(one.stderr_text.find("1 PNG in " + (r / "frames").string() + " (scene4_frame0000.png)"),
            std::string::npos)
      << one.stderr_text;
  const Result again = smallRun(r, "--no-wav");
  ASSERT_EQ(again.exit_code, 0) << again.stderr_text;
  EXPECT_NE(again.stderr_text.find(
                "; removed the last run's frames/scene4_frame0000.png and sound.wav\n"),
            std::string::npos)
      << again.stderr_text;
}

// Without --capture-every a run writes frames 0, F/4, F/2 and 3F/4.
TEST_F(ProbeCliTest, TheDefaultKeyframesAreFourPngs) {
  for (const int frames : {5, 6, 9}) {
    const fs::path r = out_ / ("r" + std::to_string(frames));
    const Result result = runOverlap("run --objects 20 --no-wav --capture-size 32x24 --frames " +
                                     std::to_string(frames) + " --out " + r.string());
    ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
    EXPECT_EQ(std::distance(fs::directory_iterator(r / "frames"), fs::directory_iterator()), 4)
        << frames;
    EXPECT_TRUE(
        fs::exists(r / "frames" / ("scene4_frame000" + std::to_string(frames / 2) + ".png")))
        << frames;
  }
}

// --growth is written as given.
TEST_F(ProbeCliTest, LatencyWritesTheGrowthAsGiven) {
  int exit_code = -1;
  const std::string csv =
      stdoutOf("latency --objects 20 --frames 2 --algo bvh --growth 1000,0.0004", &exit_code);
  EXPECT_EQ(exit_code, 0);
  EXPECT_NE(csv.find(",1000,"), std::string::npos) << csv;
  EXPECT_NE(csv.find(",0.0004,"), std::string::npos) << csv;
  EXPECT_EQ(csv.find("e+"), std::string::npos) << csv;
}

// sap's limit is said in the boxes the user asked for.
TEST_F(ProbeCliTest, SapsLimitCountsTheBoxesGiven) {
  const std::string args =
      "run --algo sap --objects 32759 --frames 1 --no-tasks --capture-every 0 "
      "--out " +
      (out_ / "r").string();
  const Result result = runOverlap(args);
  expectRefused(result, args, "asked for 32759; use sap32");
}

// An empty --input is named as empty.
TEST_F(ProbeCliTest, AnEmptyInputNameIsNamed) {
  expectRefused(runOverlap("pairs --input \"\""), "--input \"\"", "\"\" (an empty name)");
}

}  // namespace
