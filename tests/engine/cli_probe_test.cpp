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

}  // namespace
