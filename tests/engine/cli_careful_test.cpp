// A careful user's expectations, one mess per test: each test makes the mess
// and checks what docs/CLI.md promises for it.  A FIFO
// and a symlink stand in for a device node where the tests run without root.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "tests/engine/cli_test_support.h"

namespace {

using namespace overlap::testing;
namespace fs = std::filesystem;

// Every file under `folder` (relative path to contents).
std::map<std::string, std::string> snapshot(const fs::path& folder) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(folder)) {
    if (entry.is_regular_file()) {
      files[fs::relative(entry.path(), folder).string()] = fileText(entry.path());
    }
  }
  return files;
}

class CarefulCliTest : public CliTest {
 protected:
  void SetUp() override {
    CliTest::SetUp();
    fs::create_directories(out_);
  }
  fs::path record(const std::string& name, int objects = 20, int frames = 2) {
    const fs::path path = out_ / name;
    const Result result = runOverlap("record --objects " + std::to_string(objects) + " --frames " +
                                     std::to_string(frames) + " --out " + path.string());
    EXPECT_EQ(result.exit_code, 0) << result.stderr_text;
    return path;
  }
  std::string pairsOf(const fs::path& input, int* exit_code) {
    return stdoutOf("pairs --algo bf --input " + input.string(), exit_code);
  }
};

// An output that exists and is not a regular file is written
// through; a symlink's target is replaced and the link stays a link.
TEST_F(CarefulCliTest, DevicesFifosAndSymlinksAreWrittenThroughOrFollowed) {
  const fs::path stream = record("plain.aabbs");
  const std::string expected = fileText(stream);

  ASSERT_EQ(runOverlap("record --objects 20 --frames 2 --out /dev/null").exit_code, 0);
  EXPECT_TRUE(fs::is_character_file("/dev/null"));

  const fs::path fifo = out_ / "fifo.aabbs";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string through_fifo;
  std::thread reader([&] { through_fifo = fileText(fifo); });
  const Result to_fifo = runOverlap("record --objects 20 --frames 2 --out " + fifo.string());
  reader.join();
  EXPECT_EQ(to_fifo.exit_code, 0) << to_fifo.stderr_text;
  EXPECT_TRUE(fs::is_fifo(fifo));
  EXPECT_EQ(through_fifo, expected);

  const fs::path target = out_ / "target.aabbs";
  const fs::path link = out_ / "link.aabbs";
  std::ofstream(target) << "old";
  fs::create_symlink(target.filename(), link);
  ASSERT_EQ(runOverlap("record --objects 20 --frames 2 --out " + link.string()).exit_code, 0);
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_EQ(fileText(target), expected);

  // --wav into a FIFO: the sound streams through it, the FIFO stays.
  const fs::path wav_fifo = out_ / "sound.fifo";
  ASSERT_EQ(::mkfifo(wav_fifo.c_str(), 0600), 0);
  std::string wav;
  std::thread wav_reader([&] { wav = fileText(wav_fifo); });
  const Result run = runOverlap("run --objects 20 --frames 2 --capture-every 0 --wav " +
                                wav_fifo.string() + " --out " + (out_ / "run").string());
  wav_reader.join();
  EXPECT_EQ(run.exit_code, 0) << run.stderr_text;
  EXPECT_TRUE(fs::is_fifo(wav_fifo));
  EXPECT_EQ(wav.substr(0, 4), "RIFF");
  EXPECT_EQ(wav.size(), 44u + 2u * 1600u * 4u);
  EXPECT_TRUE(fs::exists(out_ / "run" / "summary.json"));
}

// A stream without a size is read a frame at a time; its header's
// counts alone allocate nothing.  The same stream through a pipe gives the
// same pairs as the file.
TEST_F(CarefulCliTest, StreamsWithoutASizeEndAtOnceOrAreReadFrameByFrame) {
  for (const char* device : {"/dev/zero", "/dev/urandom"}) {
    const Result result = runOverlap(std::string("pairs --algo cpubf --input ") + device);
    EXPECT_EQ(result.exit_code, 2) << device << ": " << result.stderr_text;
    EXPECT_NE(result.stderr_text.find(device), std::string::npos) << result.stderr_text;
  }
  const fs::path stream = record("piped.aabbs", 40, 3);
  int exit_code = -1;
  const std::string from_file = pairsOf(stream, &exit_code);
  ASSERT_EQ(exit_code, 0);
  ASSERT_GT(lineCount(from_file), 1);
  const std::string piped = shellStdout("cat " + stream.string() + " | " + OVERLAP_BINARY +
                                            " pairs --algo bf --input /dev/stdin 2>/dev/null",
                                        &exit_code);
  EXPECT_EQ(exit_code, 0);
  EXPECT_EQ(piped, from_file);

  // A header that promises 10^8 objects a frame, then ends: refused at the
  // end of what arrived, naming the frame.
  std::string header = fileText(stream).substr(0, 304);
  const std::int32_t huge = 100'000'000;
  std::memcpy(header.data() + 256, &huge, sizeof(huge));
  const fs::path lying = out_ / "lying.bin";
  std::ofstream(lying, std::ios::binary) << header << std::string(64, '\0');
  const std::string message = shellStdout("cat " + lying.string() + " | " + OVERLAP_BINARY +
                                              " pairs --algo bf --input /dev/stdin 2>&1 >/dev/null",
                                          &exit_code);
  EXPECT_EQ(exit_code, 2) << message;
  EXPECT_NE(message.find("frame 0: the stream ends after object 2 of 100000000"), std::string::npos)
      << message;
}

// SIGINT and SIGTERM stop at a frame boundary, say in one line what
// was kept, and leave the folder as the previous run left it.
TEST_F(CarefulCliTest, InterruptedRunLeavesThePreviousRunWhole) {
  const fs::path folder = out_ / "run";
  ASSERT_EQ(runOverlap("run --objects 50 --frames 4 --capture-every 2 --capture-size 32x24 --out " +
                       folder.string())
                .exit_code,
            0);
  const std::map<std::string, std::string> before = snapshot(folder);
  ASSERT_EQ(before.count("sound.wav"), 1u);
  for (const auto& [signal_number, code, name] :
       {std::tuple{SIGINT, 130, "SIGINT"}, std::tuple{SIGTERM, 143, "SIGTERM"}}) {
    Started run("run --objects 200 --frames 100000 --capture-every 1 --capture-size 32x24 --out " +
                    folder.string(),
                out_ / "err.txt");
    ASSERT_TRUE(run.waitFor("frames,")) << run.stderrText();
    run.signal(signal_number);
    const int status = run.wait();
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), code);
    const std::string err = run.stderrText();
    EXPECT_NE(err.find(std::string("stopped by ") + name + " at frame "), std::string::npos) << err;
    EXPECT_NE(err.find("kept nothing of this run"), std::string::npos) << err;
    EXPECT_EQ(snapshot(folder), before) << name;
    EXPECT_FALSE(holdsTemporaries(folder)) << name;
  }
}

// A write that fails exits 1 naming the output.
TEST_F(CarefulCliTest, FailedWritesExit1NamingTheOutput) {
  const fs::path stream = record("s.aabbs");
  for (const std::string& args : {"pairs --algo bf --input " + stream.string(),
                                  std::string("latency --objects 20 --frames 2")}) {
    int exit_code = -1;
    const std::string message =
        shellStdout(std::string(OVERLAP_BINARY) + " " + args + " 2>&1 > /dev/full", &exit_code);
    EXPECT_EQ(exit_code, 1) << args << ": " << message;
    EXPECT_NE(message.find("standard output: cannot write"), std::string::npos) << message;
  }
  const Result record_full = runOverlap("record --objects 20 --frames 2 --out /dev/full");
  EXPECT_EQ(record_full.exit_code, 1) << record_full.stderr_text;
  EXPECT_NE(record_full.stderr_text.find("/dev/full: cannot write"), std::string::npos)
      << record_full.stderr_text;
}

// Bad values and combinations exit 2 before any work,
// in one short line naming the option (both, for a conflict).
TEST_F(CarefulCliTest, BadValuesAreRefusedInOneLineBeforeAnyWork) {
  const std::string out = " --out " + out_.string();
  const std::string huge(60000, 'x');
  fs::create_directories(out_ / "dirs" / "summary.json");
  fs::create_directories(out_ / "dirs2" / "frames.csv");
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"run --frames 2 --wav \"\"" + out, "--wav \"\": the name is empty"},
      {"record --frames 2 --out \"\"", "--out \"\": the name is empty"},
      {"record --frames 2 --out " + (out_ / "new").string() + "/", "names a folder"},
      {"run --frames 2 --out " + (out_ / "dirs").string(), "summary.json: is a directory"},
      {"run --frames 2 --out " + (out_ / "dirs2").string(), "frames.csv: is a directory"},
      {"run --voices 1000000000" + out, "--voices: 1000000000 must be at most 100000"},
      {"run --agents 1000000000" + out, "--agents: 1000000000 must be at most 100000"},
      {"latency --objects 20 --frames 2 --growth nan", "--growth: nan is not a finite number"},
      {"run --task-load nan" + out, "--task-load: nan is not a finite number"},
      {"record --seed -1" + out, "--seed: -1 must be at least 0"},
      {"record --seed 18446744073709551616" + out, "must be at most 18446744073709551615"},
      {"record --seed \"\"" + out, "--seed: an empty value is not a number"},
      {"run --voices 0" + out, "--background-voices 16 (its default) must be at most --voices 0"},
      {"run --frame-time 0.00001" + out, "--frame-time 1e-05 is shorter than one sample"},
      {"run --no-tasks --voices 3" + out, "--voices and --no-tasks"},
      {"run --wav x.wav --no-wav" + out, "--wav and --no-wav"},
      {"run --sync --compare-sync" + out, "--sync and --compare-sync"},
      {"run --no-tasks --wav x.wav" + out, "--wav and --no-tasks"},
      {"record --wall-min 0" + out, "--wall-min: 0 must be above 0"},
      {"record --wall-min inf" + out, "--wall-min: inf is not a finite number"},
      {"record --scene 2 --kicks -1" + out, "--kicks: -1 must be at least 0"},
      {"run --capture-every -1" + out, "--capture-every: -1 must be at least 0"},
      {"latency --growth -1", "--growth: -1 must be at least 0"},
      {"record --objects nan" + out, "--objects: nan is not a whole number"},
      {"record --objects 3abc" + out, "--objects: 3abc is not a whole number"},
      {"record --objects \"\"" + out, "--objects: an empty value is not a number"},
      {"record --objects 0x10" + out, "--objects: 0x10 is not a whole number"},
      {"record --seed " + std::string(60000, '1') + out, "(60000 characters) must be at most"},
      {"record --wall-min " + std::string(60000, '9') + out, "(60000 characters) must be at most"},
      {"record --objects 1" + std::string(60000, 'x') + out, "(60001 characters) is not a whole"},
      {"capture --size 32x24 --capture-size 32x24" + out, "--size and --capture-size"},
      {"bogus", "unknown subcommand 'bogus'; the subcommands are run, record, pairs"},
      // Every echoed value is cut short, whatever parses it.
      {"run --solver-order " + huge + out, "(60000 characters)' is not one of coloured, serial"},
      {"run --ccd " + huge + out, "(60000 characters)' is not one of off, auto, all"},
      {"run --substeps " + huge + out, "(60000 characters) is not a whole number"},
      {"run --algo " + huge + out, "--algo: xxxxxxxxxxxxxxxxxxxx... (60000 characters) is not one"},
      {"run --algo \"\"" + out, "--algo: an empty value is not one of bf, sap"},
      {"capture --colour " + huge + out, "(60000 characters) is not one of size, contact"},
      {"capture --keyframes 1,," + huge + out, "(60003 characters)\" has an empty item"},
      {"capture --keyframes 7" + huge + ",7" + huge + out, "(60001 characters) is not a whole"},
      {"run " + huge + out, "not expected: xxxxxxxxxxxxxxxxxxxx... (60000 characters)"},
      {"run --" + huge + " a b c d e f" + out, " and 3 more"},
      {huge, "unknown subcommand 'xxxxxxxxxxxxxxxxxxxx... (60000 characters)'"},
      {"--list-algos " + huge, "'xxxxxxxxxxxxxxxxxxxx... (60000 characters)' would be ignored"},
  };
  for (const auto& [args, message] : bad) {
    const Result result = runOverlap(args);
    EXPECT_EQ(result.exit_code, 2) << args << ": " << result.stderr_text;
    EXPECT_EQ(lineCount(result.stderr_text), 1) << args << ": " << result.stderr_text;
    EXPECT_LT(result.stderr_text.size(), 160u) << args << ": " << result.stderr_text;
    EXPECT_NE(result.stderr_text.find(message), std::string::npos)
        << args << ": " << result.stderr_text;
    EXPECT_FALSE(fs::exists(out_ / "frames.csv")) << args;
  }
}

// The layout requires the fourth floats to be 0 and the names
// NUL-padded within their 128 bytes.
TEST_F(CarefulCliTest, FourthFloatsAndUnterminatedNamesAreRefused) {
  const std::string good = fileText(record("good.aabbs"));
  const float one = 1.0f, nan = std::nanf("");
  const std::vector<std::tuple<std::string, std::size_t, std::string, std::string>> cases = {
      {"w1.aabbs", 304 + 12, std::string(reinterpret_cast<const char*>(&one), 4),
       "frame 0, object 0: the fourth float of min is 1"},
      {"wnan.aabbs", 304 + 32 + 28, std::string(reinterpret_cast<const char*>(&nan), 4),
       "frame 0, object 1: the fourth float of max is nan"},
      {"name.aabbs", 0, std::string(128, 'a'), "scene name has no NUL within its 128 bytes"},
  };
  for (const auto& [name, offset, bytes, message] : cases) {
    std::string bad = good;
    bad.replace(offset, bytes.size(), bytes);
    std::ofstream(out_ / name, std::ios::binary) << bad;
    int exit_code = -1;
    EXPECT_EQ(pairsOf(out_ / name, &exit_code), "") << name;
    EXPECT_EQ(exit_code, 2) << name;
    const Result result = runOverlap("pairs --algo bf --input " + (out_ / name).string());
    EXPECT_NE(result.stderr_text.find(message), std::string::npos) << result.stderr_text;
  }
}

// A second run into the same folder removes what the first wrote
// and the second does not (old PNGs, the WAV), and nothing else.
TEST_F(CarefulCliTest, ARunsFolderNeverMixesRuns) {
  const std::string args = " --objects 50 --frames 9 --capture-size 32x24 --out " + out_.string();
  ASSERT_EQ(runOverlap("run --capture-every 4" + args).exit_code, 0);
  EXPECT_TRUE(fs::exists(out_ / "frames" / "scene4_frame0008.png"));
  std::ofstream(out_ / "notes.txt") << "mine";
  std::ofstream(out_ / "frames" / "mine.png") << "mine";
  ASSERT_EQ(runOverlap("run --capture-every 3 --no-wav" + args).exit_code, 0);
  for (const char* kept :
       {"frames/scene4_frame0000.png", "frames/scene4_frame0003.png", "frames/scene4_frame0006.png",
        "frames.csv", "summary.json", "timeline.json", "notes.txt", "frames/mine.png"}) {
    EXPECT_TRUE(fs::exists(out_ / kept)) << kept;
  }
  for (const char* removed :
       {"frames/scene4_frame0004.png", "frames/scene4_frame0008.png", "sound.wav"}) {
    EXPECT_FALSE(fs::exists(out_ / removed)) << removed;
  }
  EXPECT_FALSE(holdsTemporaries(out_));
}

// Writers of one name at once each use a temporary of their own.
TEST_F(CarefulCliTest, ConcurrentWritersOfOneNameAllSucceed) {
  const fs::path same = out_ / "same.aabbs";
  const std::string command = "for i in 1 2 3 4; do (" + std::string(OVERLAP_BINARY) +
                              " record --objects 200 --frames 3 --out " + same.string() +
                              " 2>/dev/null; echo $? > " + (out_ / "rc").string() +
                              "$i) & done; wait";
  ASSERT_EQ(std::system(command.c_str()), 0);
  for (int i = 1; i <= 4; ++i) {
    EXPECT_EQ(fileText(out_ / ("rc" + std::to_string(i))), "0\n") << i;
  }
  int exit_code = -1;
  pairsOf(same, &exit_code);
  EXPECT_EQ(exit_code, 0);
  EXPECT_FALSE(holdsTemporaries(out_));
}

// Placing ten million boxes says so on stderr while it runs (a
// progress line each second; how soon the first one comes is a timing, which
// a sanitizer's build stretches, so only its coming is asserted).  A second
// signal ends the process at once.
TEST_F(CarefulCliTest, PlacingManyBoxesShowsProgress) {
  Started record("record --objects 10000000 --frames 1 --out " + (out_ / "big.aabbs").string(),
                 out_ / "err.txt");
  EXPECT_TRUE(record.waitFor("overlap: placing 10000000 boxes: ")) << record.stderrText();
  EXPECT_NE(record.stderrText().find(" s elapsed"), std::string::npos) << record.stderrText();
  record.signal(SIGTERM);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  record.signal(SIGTERM);
  record.wait();
  EXPECT_FALSE(fs::exists(out_ / "big.aabbs"));
}

// The benchmark names a corrupt cached stream and exits 2.
TEST_F(CarefulCliTest, BenchmarkNamesACorruptCachedStream) {
  const fs::path cached = out_ / "scene4_seed42_n100_f2.aabbs";
  std::ofstream(cached) << "not a stream";
  const std::string command = std::string(OVERLAP_BENCH_BINARY) +
                              " --objects 100 --algos bf --big-objects 0 --record-frames 2 "
                              "--warmup 0 --repeats 1 --streams " +
                              out_.string() + " --out " + (out_ / "result").string() + " 2> " +
                              (out_ / "err.txt").string();
  const int status = std::system(command.c_str());
  EXPECT_EQ(WEXITSTATUS(status), 2);
  EXPECT_NE(fileText(out_ / "err.txt").find(cached.string()), std::string::npos)
      << fileText(out_ / "err.txt");
}

// The benchmark refuses an --out whose results would replace an --input,
// by name, through a link and '..', through a folder not made yet and '..',
// and the stream is left as it was.
TEST_F(CarefulCliTest, BenchmarkNeverWritesItsResultsOverItsInput) {
  const fs::path folder = out_ / "r";
  fs::create_directories(folder);
  ASSERT_EQ(std::system((std::string(OVERLAP_BINARY) + " generate --objects 20 --frames 2 --out " +
                         (folder / "z.csv").string() + " 2>/dev/null")
                            .c_str()),
            0);
  const std::string stream = fileText(folder / "z.csv");
  fs::create_directory_symlink("r", out_ / "lk");
  // A folder not made yet counts as a folder: `new/../z` is r/z, and a link
  // after it is followed (`new/../lk/z`).
  for (const std::string out :
       {(folder / "z").string(), (out_ / "lk" / ".." / "r" / "z").string(),
        (folder / "new" / ".." / "z").string(), (out_ / "new" / ".." / "lk" / "z").string()}) {
    const std::string command =
        std::string(OVERLAP_BENCH_BINARY) + " --input " + (folder / "z.csv").string() +
        " --algos bvh --warmup 0 --repeats 1 --out " + out + " 2> " + (out_ / "err.txt").string();
    const int status = std::system(command.c_str());
    EXPECT_EQ(WEXITSTATUS(status), 2) << out;
    EXPECT_NE(fileText(out_ / "err.txt").find("which the results would replace"), std::string::npos)
        << fileText(out_ / "err.txt");
    EXPECT_EQ(fileText(folder / "z.csv"), stream) << out;
  }
  EXPECT_FALSE(fs::exists(folder / "new"));
  EXPECT_FALSE(fs::exists(out_ / "new"));
}

// A long capture says at the start how long it will take.
TEST_F(CarefulCliTest, ALongCaptureSaysHowLongItWillTake) {
  Started capture("capture --objects 100 --keyframes 0,1000000 --capture-size 32x24 --out " +
                      (out_ / "shots").string(),
                  out_ / "err.txt");
  EXPECT_TRUE(capture.waitFor("1000001 frames; at the first frames' pace the whole takes about"))
      << capture.stderrText();
  capture.signal(SIGINT);
  const int status = capture.wait();
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 130) << capture.stderrText();
  EXPECT_FALSE(holdsTemporaries(out_ / "shots"));
}

}  // namespace
