// Signals, pipes and temporaries (docs/CLI.md, "Signals", "Outputs"): each
// test makes the mess one row of a hostile probe's table describes, small
// enough to run in a second or two, and checks what a careful user expects.
// A FIFO stands in for a slow or vanished reader or writer.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/engine/cli_test_support.h"

namespace {

using namespace overlap::testing;
namespace fs = std::filesystem;

// A .aabbs stream of `frames` + 1 frames of the "line" scene: box i is
// (0.5 i, 0, 0)-(0.5 i + 1, 1, 1), so i pairs with i + 1; `nan_last`
// makes the last frame's object 1 have min.x NaN.
std::string lineStream(int objects, int frames, bool nan_last = false) {
  std::string bytes(304, '\0');
  std::memcpy(bytes.data(), "line", 4);
  std::memcpy(bytes.data() + 128, "box", 3);
  const std::int32_t counts[4] = {objects, frames, 0, 0};
  std::memcpy(bytes.data() + 256, counts, sizeof(counts));
  const float world[8] = {-1, -1, -1, 0, 0.5f * static_cast<float>(objects) + 2, 2, 2, 0};
  std::memcpy(bytes.data() + 272, world, sizeof(world));
  for (int frame = 0; frame <= frames; ++frame) {
    for (int i = 0; i < objects; ++i) {
      const float x = 0.5f * static_cast<float>(i);
      float box[8] = {x, 0, 0, 0, x + 1, 1, 1, 0};
      if (nan_last && frame == frames && i == 1) box[0] = std::nanf("");
      bytes.append(reinterpret_cast<const char*>(box), sizeof(box));
    }
  }
  return bytes;
}

bool exitedWith(int status, int code) {
  return WIFEXITED(status) && WEXITSTATUS(status) == code;
}

// The peak RSS of `command` (run by /bin/sh, its output discarded), in
// bytes, expecting it to exit with `expected_exit`.
double peakBytesOf(const std::string& command, int expected_exit) {
  const std::string line = "exec " + command + " > /dev/null 2>&1";
  const char* argv[] = {"/bin/sh", "-c", line.c_str(), nullptr};
  pid_t pid = 0;
  EXPECT_EQ(posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ), 0);
  int status = 0;
  rusage usage{};
  ::wait4(pid, &status, 0, &usage);
  EXPECT_TRUE(exitedWith(status, expected_exit)) << command;
  return static_cast<double>(usage.ru_maxrss) * 1024;  // kB on Linux
}

// A PID no process has: a child that has been waited for.
pid_t deadPid() {
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ::waitpid(child, nullptr, 0);
  return child;
}

class SignalsCliTest : public CliTest {
 protected:
  void SetUp() override {
    CliTest::SetUp();
    fs::create_directories(out_);
  }
  fs::path write(const std::string& name, const std::string& bytes) {
    std::ofstream(out_ / name, std::ios::binary) << bytes;
    return out_ / name;
  }
  fs::path fifo(const std::string& name) {
    const fs::path path = out_ / name;
    EXPECT_EQ(::mkfifo(path.c_str(), 0600), 0);
    return path;
  }
};

// Generate stops at a frame boundary on SIGINT, and on SIGTERM under
// the strongest gravity; the old file is kept either way.
TEST_F(SignalsCliTest, GenerateStopsOnSignalsAndKeepsTheOldFile) {
  const fs::path out = write("g.aabbs", "old\n");
  const std::vector<std::tuple<std::string, int, int, std::string>> cases = {
      {"--objects 200 --frames 1000000", SIGINT, 130, "overlap generate: "},
      {"--gravity 1e6 --gravity-scale 1e6 --frame-time 1 --objects 200 --frames 1000000", SIGTERM,
       143, "overlap generate: "},
  };
  for (const auto& [args, signal_number, code, progress] : cases) {
    Started generate("generate " + args + " --out " + out.string(), out_ / "err.txt");
    ASSERT_TRUE(generate.waitFor(progress)) << generate.stderrText();
    generate.signal(signal_number);
    const int status = generate.wait();
    EXPECT_TRUE(exitedWith(status, code)) << args << ": " << generate.stderrText();
    EXPECT_NE(generate.stderrText().find("stopped by SIG"), std::string::npos)
        << generate.stderrText();
    EXPECT_EQ(fileText(out), "old\n") << args;
    EXPECT_FALSE(holdsTemporaries(out_)) << args;
  }
}

// A FIFO whose reader goes away: exit 1 naming the output, every
// temporary removed (not a silent death by SIGPIPE).
TEST_F(SignalsCliTest, AFifoReaderThatLeavesEndsTheRunWithExit1) {
  const fs::path wav = fifo("w.fifo");
  const fs::path stream = fifo("s.fifo");
  const std::vector<std::pair<std::string, fs::path>> cases = {
      {"run --objects 100 --frames 30 --capture-every 2 --capture-size 32x24 --wav " +
           wav.string() + " --out " + (out_ / "rf").string(),
       wav},
      {"generate --objects 2000 --frames 20 --out " + stream.string(), stream},
  };
  for (const auto& [args, output] : cases) {
    std::thread reader([path = output] {
      const int fd = ::open(path.c_str(), O_RDONLY);
      char head[100];
      for (std::size_t got = 0; got < sizeof(head);) {
        const ssize_t read = ::read(fd, head + got, sizeof(head) - got);
        if (read <= 0) break;
        got += static_cast<std::size_t>(read);
      }
      ::close(fd);
    });
    const Result result = runOverlap(args);
    reader.join();
    EXPECT_EQ(result.exit_code, 1) << args << ": " << result.stderr_text;
    EXPECT_NE(result.stderr_text.find(output.string() + ": cannot write: Broken pipe"),
              std::string::npos)
        << result.stderr_text;
    EXPECT_FALSE(holdsTemporaries(out_)) << args;
  }
}

// A FIFO whose reader holds it open but never reads: the WAV's write fills
// it and blocks in the sound job's thread, which no signal reaches; a stop
// still ends the run at once with its line (the write looks for it).
TEST_F(SignalsCliTest, AStopEndsARunBlockedOnAReaderThatNeverReads) {
  const fs::path wav = fifo("full.fifo");
  const int held = ::open(wav.c_str(), O_RDWR | O_CLOEXEC);  // a reader that never reads
  ASSERT_GE(held, 0);
  Started run("run --objects 20 --frames 100000 --capture-every 0 --wav " + wav.string() +
                  " --out " + (out_ / "blocked").string(),
              out_ / "err.txt");
  ASSERT_TRUE(run.waitFor("default broadphase")) << run.stderrText();
  std::this_thread::sleep_for(std::chrono::milliseconds(2000));  // the FIFO full by now
  run.signal(SIGTERM);
  EXPECT_TRUE(exitedWith(run.wait(), 143)) << run.stderrText();
  EXPECT_NE(run.stderrText().find("stopped by SIGTERM"), std::string::npos) << run.stderrText();
  EXPECT_NE(run.stderrText().find("(written as it went)"), std::string::npos) << run.stderrText();
  EXPECT_FALSE(fs::exists(out_ / "blocked"));
  ::close(held);
}

// Standard error that takes nothing more (a FIFO full, a terminal stopped
// with Ctrl-S), from the first message or after some (progress lines come
// each second from a timer): the messages blocked on it, and the stop's own
// line, never hold a stop; the run ends with the stop's status, its outputs
// unpublished.
TEST_F(SignalsCliTest, AStopEndsARunWhoseStandardErrorTakesNothing) {
  for (const bool read_at_first : {false, true}) {
    const fs::path messages = fifo(read_at_first ? "later.fifo" : "first.fifo");
    const int held = ::open(messages.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
    ASSERT_GE(held, 0);
    const auto fill = [held] {  // from here on, no one reads
      const std::string filler(4096, 'x');
      while (::write(held, filler.data(), filler.size()) > 0) {
      }
    };
    if (!read_at_first) fill();
    Started run("run --objects 20 --frames 100000 --capture-every 0 --no-wav --out " +
                    (out_ / "blocked").string(),
                messages);
    if (read_at_first) {  // its first messages and progress lines are read
      char drained[4096];
      for (int i = 0; i < 30; ++i) {
        while (::read(held, drained, sizeof(drained)) > 0) {
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
      }
      fill();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2500));  // a progress line blocked
    run.signal(SIGTERM);
    ASSERT_TRUE(run.endsWithin(std::chrono::seconds(15))) << "read at first: " << read_at_first;
    EXPECT_TRUE(exitedWith(run.wait(), 143)) << "read at first: " << read_at_first;
    EXPECT_FALSE(fs::exists(out_ / "blocked"));
    ::close(held);
  }
}

// Standard error that no write can reach (a FIFO's read end, `2< f.fifo`,
// its writer still there): the messages are dropped at once, as a failed
// write drops them, and the run goes on; it never waits for room that
// cannot come.
TEST_F(SignalsCliTest, AStandardErrorNoWriteCanReachIsNotWaitedFor) {
  const fs::path messages = fifo("read_end.fifo");
  const int writer = ::open(messages.c_str(), O_RDWR | O_CLOEXEC);  // no EOF, no hangup
  ASSERT_GE(writer, 0);
  const std::string command = "timeout 20 " + std::string(OVERLAP_BINARY) +
                              " run --objects 20 --frames 2 --capture-every 0 --no-wav --out " +
                              (out_ / "reached").string() + " 2< " + messages.string();
  const int status = std::system(command.c_str());
  ::close(writer);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "124: it waited for room on stderr";
  EXPECT_TRUE(fs::exists(out_ / "reached" / "frames.csv"));
}

// SIGHUP stops a run like SIGTERM; a run clears the temporaries that
// a killed run of the program left (dead writer), and nothing else: not a
// live writer's, not a file of another pattern.
// The renderer's start (OSMesa and LLVM opened in its process) may take
// long: a stop signal ends the wait on it at once, not when it is done.
TEST_F(SignalsCliTest, AStopDuringTheRenderersStartEndsTheWaitAtOnce) {
  const fs::path mark = out_ / "osmesa_loading";
  Started capture(
      "capture --objects 20 --keyframes 0 --capture-size 32x24 --out " + (out_ / "shots").string(),
      out_ / "err.txt",
      "env LD_LIBRARY_PATH=" + std::string(OVERLAP_SLOW_OSMESA_DIR) +
          " OVERLAP_SLOW_OSMESA_MARK=" + mark.string() + " " + OVERLAP_BINARY);
  for (int i = 0; i < 300 && !fs::exists(mark); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_TRUE(fs::exists(mark)) << capture.stderrText();
  const auto signalled = std::chrono::steady_clock::now();
  capture.signal(SIGTERM);
  const int status = capture.wait();
  EXPECT_LT(std::chrono::steady_clock::now() - signalled, std::chrono::seconds(20));
  EXPECT_TRUE(exitedWith(status, 143)) << capture.stderrText();
  EXPECT_NE(capture.stderrText().find("stopped by SIGTERM at the start of OSMesa's renderer"),
            std::string::npos)
      << capture.stderrText();
  EXPECT_FALSE(fs::exists(out_ / "shots"));
}

TEST_F(SignalsCliTest, SighupStopsARunAndStaleTemporariesAreCleared) {
  const fs::path folder = out_ / "rk";
  Started run("run --objects 100 --frames 100000 --capture-every 1 --capture-size 32x24 --out " +
                  folder.string(),
              out_ / "err.txt");
  ASSERT_TRUE(run.waitFor("frames,")) << run.stderrText();
  run.signal(SIGHUP);
  const int status = run.wait();
  EXPECT_TRUE(exitedWith(status, 129)) << run.stderrText();
  EXPECT_NE(run.stderrText().find("stopped by SIGHUP at frame "), std::string::npos)
      << run.stderrText();
  EXPECT_FALSE(holdsTemporaries(folder));

  const std::string dead = std::to_string(deadPid());
  const std::string live = std::to_string(::getpid());
  const std::vector<std::string> stale = {
      ".sound.wav.overlap-" + dead + "-a1B2c3",
      "frames/.scene4_frame0000.png.overlap-" + dead + "-Zz9yY8",
      "frames/.scene4_frame0400.png.overlap-" + dead + "-q1w2e3"};
  const std::vector<std::string> kept = {
      ".frames.csv.overlap-" + live + "-a1B2c3", ".notes.overlap-" + dead,
      "notes.overlap-" + dead + "-abcdef", "frames/.mine.overlap-" + dead + "-abc"};
  fs::create_directories(folder / "frames");
  for (const std::string& name : stale) write("rk/" + name, "stale");
  for (const std::string& name : kept) write("rk/" + name, "mine");
  const Result next =
      runOverlap("run --objects 50 --frames 2 --capture-every 1 --capture-size 32x24 --out " +
                 folder.string());
  EXPECT_EQ(next.exit_code, 0) << next.stderr_text;
  for (const std::string& name : stale) EXPECT_FALSE(fs::exists(folder / name)) << name;
  for (const std::string& name : kept) EXPECT_EQ(fileText(folder / name), "mine") << name;
}

// A signal that lands while the outputs are renamed into place (strace
// delivers it at the first rename) stops nothing: every output holds the
// new run, the exit is 0, and a line says the signal came too late.
TEST_F(SignalsCliTest, ASignalDuringThePublicationStopsNothingAndSaysSo) {
  if (std::system("command -v strace > /dev/null 2>&1") != 0) GTEST_SKIP() << "no strace here";
  const fs::path folder = out_ / "published";
  ASSERT_EQ(
      runOverlap("run --objects 30 --frames 2 --capture-every 0 --no-wav --out " + folder.string())
          .exit_code,
      0);
  const std::string before = fileText(folder / "frames.csv");
  for (const char* signal : {"SIGTERM", "SIGINT"}) {
    const Result run = runCommand(std::string("strace -f -o /dev/null -e inject=rename:signal=") +
                                  signal + ":when=1 " + OVERLAP_BINARY +
                                  " run --objects 30 --frames 5 --capture-every 0 --no-wav --out " +
                                  folder.string());
    EXPECT_EQ(run.exit_code, 0) << signal << ": " << run.stderr_text;
    EXPECT_NE(run.stderr_text.find(std::string(signal) +
                                   " came after the outputs were published: they hold this run"),
              std::string::npos)
        << run.stderr_text;
    EXPECT_NE(fileText(folder / "frames.csv"), before) << "the new run's frames are published";
  }
}

// Memory bounds checked before allocating (the boxes and what the
// broadphase holds for them), exit 2 naming the input or option and the
// memory it needs; generate writes as it goes (frame 0
// arrives while later frames are still being made) and refuses a file its
// disk cannot hold.
TEST_F(SignalsCliTest, MemoryAndDiskBoundsAreCheckedBeforeAnyWork) {
  std::string huge = lineStream(2, 1).substr(0, 304 + 64);
  const std::int32_t most = 2147483647;
  std::memcpy(huge.data() + 256, &most, sizeof(most));
  const fs::path header = write("huge.bin", huge);
  const fs::path line = write("line5k.aabbs", lineStream(5000, 1));
  const fs::path sparse = write("line100k.aabbs", lineStream(100000, 1));
  const std::vector<std::pair<std::string, std::string>> refused = {
      {"cat " + header.string() + " | " + OVERLAP_BINARY +
           " pairs --algo bf --max-memory 1000 --input /dev/stdin",
       "--input /dev/stdin: a frame of 2147483647 boxes with --algo bf needs 352.2 GB, above the "
       "memory limit 1.0 GB (--max-memory)"},
      {std::string(OVERLAP_BINARY) + " pairs --algo cpubf --max-memory 1 --input " + line.string(),
       "a frame of 5000 boxes with --algo cpubf needs 3.5 MB"},
      {std::string(OVERLAP_BENCH_BINARY) +
           " --algos cpubf --warmup 0 --repeats 1 --max-memory 1 "
           "--input " +
           line.string() + " --out " + (out_ / "b").string(),
       "n=5000 with --algos cpubf needs 3.5 MB"},
      // What the broadphase holds for each box counts, not only the box
      // (100000 boxes are 3.2 MB).
      {std::string(OVERLAP_BINARY) + " pairs --algo cpusap --max-memory 20 --input " +
           sparse.string(),
       "a frame of 100000 boxes with --algo cpusap needs 48.4 MB"},
      {std::string(OVERLAP_BINARY) + " generate --objects 10000000 --frames 1000000 --out " +
           (out_ / "g.aabbs").string(),
       "g.aabbs: needs 320.0 TB, and its folder has"},
  };
  for (const auto& [command, message] : refused) {
    const Result result = runCommand(command);
    EXPECT_EQ(result.exit_code, 2) << command << ": " << result.stderr_text;
    EXPECT_NE(result.stderr_text.find(message), std::string::npos) << result.stderr_text;
  }
  EXPECT_FALSE(fs::exists(out_ / "b.csv"));
  EXPECT_FALSE(fs::exists(out_ / "g.aabbs"));

  // The benchmark holds every pipe it reads until it ends: two that each
  // fit the limit, but not together, are refused at the second's header.
  const fs::path pipe_stream = write("line20k.aabbs", lineStream(20000, 1));
  const fs::path first = fifo("first.fifo"), second = fifo("second.fifo");
  // The writers hold no descriptor of ours, and give up in a minute.
  const std::string writer = "(timeout 60 cat " + pipe_stream.string() + " > ";
  const Result both =
      runCommand(writer + first.string() + " 2>/dev/null &) ; " + writer + second.string() +
                 " 2>/dev/null &) ; " + OVERLAP_BENCH_BINARY +
                 " --algos cpusap --warmup 0 --repeats 1 --max-memory 2 --input " + first.string() +
                 " " + second.string() + " --out " + (out_ / "p").string());
  EXPECT_EQ(both.exit_code, 2) << both.stderr_text;
  EXPECT_NE(both.stderr_text.find("held whole beside 1.3 MB of the pipes before it"),
            std::string::npos)
      << both.stderr_text;
  EXPECT_FALSE(fs::exists(out_ / "p.csv"));

  const fs::path stream = fifo("g.fifo");
  Started generate("generate --objects 2000 --frames 1000000 --out " + stream.string(),
                   out_ / "err.txt");
  const int fd = ::open(stream.c_str(), O_RDONLY);
  std::string frame0(304 + 2000 * 32, '\0');
  std::size_t got = 0;
  while (got < frame0.size()) {
    const ssize_t read = ::read(fd, frame0.data() + got, frame0.size() - got);
    if (read <= 0) break;
    got += static_cast<std::size_t>(read);
  }
  EXPECT_EQ(got, frame0.size()) << "frame 0 arrives before the millionth frame is made";
  generate.signal(SIGINT);
  EXPECT_TRUE(exitedWith(generate.wait(), 130)) << generate.stderrText();
  ::close(fd);
}

// cpusap on identical boxes (every pair overlaps): memory bounded per
// pair, as docs/CLI.md states (72 to 144 bytes a pair in the cache; 250 allowed here).
TEST_F(SignalsCliTest, MemoryGrowsBoundedPerPair) {
#if defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "ThreadSanitizer's shadow memory is counted in the peak RSS this test reads";
#endif
  std::string identical = lineStream(1000, 1);
  for (std::size_t box = 304; box < identical.size(); box += 32) {
    const float same[8] = {0, 0, 0, 0, 1, 1, 1, 0};
    std::memcpy(identical.data() + box, same, sizeof(same));
  }
  const fs::path many = write("ident1k.aabbs", identical);
  const fs::path few = write("line2.aabbs", lineStream(2, 1));
  const auto peakBytes = [&](const fs::path& input) {
    return peakBytesOf(
        std::string(OVERLAP_BINARY) + " pairs --algo cpusap --input " + input.string(), 0);
  };
  const double pairs = 1000.0 * 999 / 2;
  EXPECT_LT(peakBytes(many) - peakBytes(few), 250 * pairs);
}

// Pairs that memory cannot hold: 4000 identical boxes make 8 million pairs a
// frame.  Under --max-memory every CPU broadphase and the benchmark exit 2
// naming the pairs and the memory they need.  Under ulimit -v (not with a
// sanitizer, whose shadow memory needs the address space) so do Bullet's
// broadphases and cpubf, whose pairs reach the cache one by one or before
// its lists grow; cpusap's own pair lists may run out first, which is exit 1
// naming the memory.  Never a signal.
TEST_F(SignalsCliTest, PairsBeyondTheMemoryLimitAreRefusedWithTheirCountAndSize) {
  std::string identical = lineStream(4000, 1);
  for (std::size_t box = 304; box < identical.size(); box += 32) {
    const float same[8] = {0, 0, 0, 0, 1, 1, 1, 0};
    std::memcpy(identical.data() + box, same, sizeof(same));
  }
  const fs::path ident = write("ident4k.aabbs", identical);
  const auto expectRefused = [](const Result& result, const std::string& label) {
    EXPECT_EQ(result.exit_code, 2) << label << ": " << result.stderr_text;
    EXPECT_NE(result.stderr_text.find(" pairs need "), std::string::npos) << result.stderr_text;
    EXPECT_NE(result.stderr_text.find("above the memory limit"), std::string::npos);
  };
  for (const char* algorithm : {"bf", "sap", "bvh", "cpubf", "cpusap"}) {
    expectRefused(runOverlap(std::string("pairs --max-memory 300 --algo ") + algorithm +
                             " --input " + ident.string()),
                  algorithm);
  }
#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
  // The limit holds for what the run allocates: its peak RSS above the same
  // command's on two boxes (the program and its libraries).  Our finders
  // stop collecting a frame's pairs at the most the limit could hold,
  // Bullet's hand them to the cache one by one.
  const fs::path two = write("line2.aabbs", lineStream(2, 1));
  for (const char* algorithm : {"bvh", "cpubf", "cpusap"}) {
    const std::string pairs =
        std::string(OVERLAP_BINARY) + " pairs --max-memory 100 --algo " + algorithm + " --input ";
    const double held =
        peakBytesOf(pairs + ident.string(), 2) - peakBytesOf(pairs + two.string(), 0);
    EXPECT_LT(held, 100e6) << algorithm << ": " << held << " bytes above two boxes' run";
  }
#endif
  expectRefused(runCommand(std::string(OVERLAP_BENCH_BINARY) +
                           " --algos cpusap --warmup 0 --repeats 1 --max-memory 300 --input " +
                           ident.string() + " --out " + (out_ / "b").string()),
                "benchmark");
  EXPECT_FALSE(fs::exists(out_ / "b.csv"));
#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
  const std::string ulimit = "ulimit -v 600000; ";
  for (const char* algorithm : {"bf", "sap", "bvh", "cpubf"}) {
    expectRefused(runCommand("(" + ulimit + OVERLAP_BINARY + " pairs --algo " + algorithm +
                             " --input " + ident.string() + ")"),
                  algorithm);
  }
  // A --max-memory above the ulimit cannot lift it.
  const Result above =
      runCommand("(" + ulimit + OVERLAP_BINARY + " pairs --algo bvh --max-memory 5000 --input " +
                 ident.string() + ")");
  expectRefused(above, "bvh, --max-memory above ulimit -v");
  EXPECT_NE(above.stderr_text.find("(ulimit -v, below --max-memory)"), std::string::npos)
      << above.stderr_text;
  const Result cpusap = runCommand("(" + ulimit + OVERLAP_BINARY + " pairs --algo cpusap --input " +
                                   ident.string() + ")");
  EXPECT_TRUE(cpusap.exit_code == 2 || cpusap.exit_code == 1) << cpusap.stderr_text;
  EXPECT_TRUE(cpusap.stderr_text.find(" pairs need ") != std::string::npos ||
              cpusap.stderr_text.find("out of memory") != std::string::npos)
      << cpusap.stderr_text;
#endif
}

// sap32 on 30000 boxes shows progress while its first frame (n^2
// insertions) runs, and a SIGINT stops it within that frame.
TEST_F(SignalsCliTest, ALongFirstFrameShowsProgressAndStopsOnSigint) {
  const fs::path stream = out_ / "g30k.aabbs";
  ASSERT_EQ(runOverlap("generate --objects 30000 --frames 1 --out " + stream.string()).exit_code,
            0);
  Started pairs("pairs --algo sap32 --input " + stream.string(), out_ / "err.txt");
  ASSERT_TRUE(pairs.waitFor("overlap pairs: 0/2 frames")) << pairs.stderrText();
  pairs.signal(SIGINT);
  const int status = pairs.wait();
  EXPECT_TRUE(exitedWith(status, 130)) << pairs.stderrText();
  EXPECT_NE(pairs.stderrText().find("stopped by SIGINT at "), std::string::npos)
      << pairs.stderrText();
}

// From a pipe, the frames before a bad one are printed, then exit 2.
TEST_F(SignalsCliTest, APipeGetsTheFramesBeforeABadOne) {
  const fs::path bad = write("badlast.aabbs", lineStream(2, 2, true));
  int exit_code = -1;
  const std::string piped = shellStdout(
      "cat " + bad.string() + " | " + OVERLAP_BINARY + " pairs --algo bf --input /dev/stdin",
      &exit_code);
  EXPECT_EQ(exit_code, 2);
  EXPECT_EQ(piped, "frame,a,b\n0,0,1\n1,0,1\n");
  EXPECT_EQ(stdoutOf("pairs --algo bf --input " + bad.string(), &exit_code), "");
  EXPECT_EQ(exit_code, 2);
}

// A FIFO with no writer, a writer that stalls, a --wav FIFO with no
// reader: each wait is said on stderr, and the first SIGINT ends it with
// the "stopped by SIGINT" line and 130.
TEST_F(SignalsCliTest, WaitsOnFifosSayTheyWaitAndStopOnSigint) {
  const fs::path input = fifo("in.fifo");
  const std::string header = lineStream(4, 2).substr(0, 304 + 32);  // a header and one box
  int writer = -1;
  std::thread stalling([&] {
    writer = ::open(input.c_str(), O_WRONLY);
    ASSERT_EQ(::write(writer, header.data(), header.size()), static_cast<ssize_t>(header.size()));
  });
  Started pairs("pairs --algo bf --input " + input.string(), out_ / "pairs.txt");
  stalling.join();
  ASSERT_TRUE(pairs.waitFor("waiting for data on " + input.string())) << pairs.stderrText();
  pairs.signal(SIGINT);
  EXPECT_TRUE(exitedWith(pairs.wait(), 130)) << pairs.stderrText();
  EXPECT_NE(pairs.stderrText().find("stopped by SIGINT at frame 0 of 3"), std::string::npos)
      << pairs.stderrText();
  ::close(writer);

  const fs::path wav = fifo("nobody.fifo");
  Started run("run --objects 20 --frames 2 --capture-every 0 --wav " + wav.string() + " --out " +
                  (out_ / "r").string(),
              out_ / "run.txt");
  ASSERT_TRUE(run.waitFor("waiting for a reader to open " + wav.string())) << run.stderrText();
  run.signal(SIGINT);
  EXPECT_TRUE(exitedWith(run.wait(), 130)) << run.stderrText();
  EXPECT_NE(run.stderrText().find("stopped by SIGINT at the wait for a reader of"),
            std::string::npos)
      << run.stderrText();
  EXPECT_FALSE(holdsTemporaries(out_));
}

// Stdout closed early (`| head`): exit 1 naming standard output,
// not a silent death by SIGPIPE.
TEST_F(SignalsCliTest, AClosedStandardOutputExits1) {
  const fs::path stream = write("line.aabbs", lineStream(20000, 1));  // 40000 rows
  const Result result =
      runCommand("bash -c '" + std::string(OVERLAP_BINARY) + " pairs --algo cpusap --input " +
                 stream.string() + " | head -c 1 > /dev/null; exit ${PIPESTATUS[0]}'");
  EXPECT_EQ(result.exit_code, 1) << result.stderr_text;
  EXPECT_NE(result.stderr_text.find("standard output: cannot write: Broken pipe"),
            std::string::npos)
      << result.stderr_text;
}

// The benchmark keeps the signal promise: the "stopped" line, 130,
// nothing written.
TEST_F(SignalsCliTest, TheBenchmarkStopsOnSigint) {
  const fs::path stream = write("s.aabbs", lineStream(200, 8));
  Started bench("--input " + stream.string() + " --algos bf --warmup 0 --repeats 1000 --out " +
                    (out_ / "b").string(),
                out_ / "err.txt", OVERLAP_BENCH_BINARY);
  ASSERT_TRUE(bench.waitFor("repeat 1/")) << bench.stderrText();
  bench.signal(SIGINT);
  EXPECT_TRUE(exitedWith(bench.wait(), 130)) << bench.stderrText();
  EXPECT_NE(bench.stderrText().find("overlap_bench_broadphase: stopped by SIGINT at n=200"),
            std::string::npos)
      << bench.stderrText();
  EXPECT_FALSE(fs::exists(out_ / "b.csv"));
  EXPECT_FALSE(holdsTemporaries(out_));
}

// A run of many boxes stops while it places them or adds them to the
// broadphase (a sweep and prune adds each in time proportional to those it
// holds), and takes its world apart at once; nothing is written.
TEST_F(SignalsCliTest, ARunStopsWhileItPlacesItsBoxes) {
  const fs::path folder = out_ / "many";
  Started run("run --algo sap32 --objects 200000 --frames 1 --no-tasks --capture-every 0 --out " +
                  folder.string(),
              out_ / "err.txt");
  ASSERT_TRUE(run.waitFor("overlap: placing 200000 boxes: ")) << run.stderrText();
  run.signal(SIGINT);
  EXPECT_TRUE(exitedWith(run.wait(), 130)) << run.stderrText();
  const std::string err = run.stderrText();
  EXPECT_TRUE(err.find("stopped by SIGINT at placing box") != std::string::npos ||
              err.find("stopped by SIGINT at adding box") != std::string::npos)
      << err;
  EXPECT_FALSE(fs::exists(folder / "summary.json"));
  EXPECT_FALSE(holdsTemporaries(out_));
}

// A signal during one long frame (cpubf's search over 200 000 boxes: a
// second or more a frame even on 16 cores; 60 000 under a sanitizer, which
// is ten times slower) stops the search within it, and the stop line says
// what already went to stdout (the first frame's rows, flushed past a
// megabyte) instead of "kept nothing".  The signal goes once the progress
// counts a frame done, however fast the machine.
TEST_F(SignalsCliTest, ASignalStopsALongFrameAndTheStopLineNamesWhatWasSent) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  constexpr int kBoxes = 60000;
#else
  constexpr int kBoxes = 200000;
#endif
  const fs::path stream = write("line.aabbs", lineStream(kBoxes, 3));  // 2 rows a box a frame
  Started pairs("pairs --algo cpubf --input " + stream.string(), out_ / "err.txt");
  ASSERT_TRUE(pairs.waitFor("/4 frames, ")) << pairs.stderrText();
  if (pairs.stderrText().find("0/4 frames, ") != std::string::npos) {
    ASSERT_TRUE(pairs.waitFor("1/4 frames, ")) << pairs.stderrText();
  }
  pairs.signal(SIGINT);
  EXPECT_TRUE(exitedWith(pairs.wait(), 130)) << pairs.stderrText();
  const std::string err = pairs.stderrText();
  EXPECT_NE(err.find("stopped by SIGINT at "), std::string::npos) << err;
  EXPECT_NE(err.find("standard output's rows of frame"), std::string::npos) << err;
  EXPECT_EQ(err.find("kept nothing of this run"), std::string::npos) << err;
}

// --task-load's calibration says it is running and stops at the first
// signal, before any output (the WAV's temporary included) is opened.
TEST_F(SignalsCliTest, TheTaskLoadCalibrationShowsProgressAndStopsAtOnce) {
  const fs::path folder = out_ / "calibrated";
  Started run(
      "run --objects 1000 --frames 64 --task-load 50 --capture-every 0 --out " + folder.string(),
      out_ / "err.txt");
  ASSERT_TRUE(run.waitFor("overlap: calibrating --task-load 50: ")) << run.stderrText();
  run.signal(SIGTERM);
  EXPECT_TRUE(exitedWith(run.wait(), 143)) << run.stderrText();
  EXPECT_NE(run.stderrText().find("stopped by SIGTERM at the --task-load calibration"),
            std::string::npos)
      << run.stderrText();
  EXPECT_FALSE(holdsTemporaries(out_));
  EXPECT_FALSE(fs::exists(folder / "sound.wav"));
}

}  // namespace
