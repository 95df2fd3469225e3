// Every program under a shrinking address space (ulimit -v): from the
// smallest limit at which it starts up to one at which it succeeds, each
// run exits 0, 1 ("out of memory") or 2, never by a signal, and leaves no
// temporary behind and, failing, publishes nothing.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "tests/engine/cli_test_support.h"

namespace overlap::testing {
namespace {

namespace fs = std::filesystem;

struct Outcome {
  int exit_code;  // 128 + N: ended by signal N
  std::string stderr_text;
};

// `binary ARGS` in `folder` under `ulimit -v kilobytes`.
Outcome runLimited(const fs::path& folder, const std::string& binary, const std::string& args,
                   long kilobytes) {
  const fs::path err = folder / "stderr.txt";
  const std::string command = "cd " + folder.string() + " && (ulimit -v " +
                              std::to_string(kilobytes) + "; exec " + binary + " " + args +
                              ") > /dev/null 2> " + err.string();
  const int status = std::system(command.c_str());
  const int code = WIFSIGNALED(status) ? 128 + WTERMSIG(status) : WEXITSTATUS(status);
  return {code, fileText(err)};
}

// Every regular file under `folder` but the runner's stderr.
std::vector<fs::path> filesLeft(const fs::path& folder) {
  std::vector<fs::path> files;
  for (const auto& entry : fs::recursive_directory_iterator(folder)) {
    if (entry.is_regular_file() && entry.path().filename() != "stderr.txt") {
      files.push_back(entry.path());
    }
  }
  return files;
}

class MemoryCliTest : public CliTest {
 protected:
  void SetUp() override {
    CliTest::SetUp();
    fs::create_directories(out_);
    stream_ = out_ / "in.aabbs";
    ASSERT_EQ(runOverlap("generate --objects 300 --frames 3 --out " + stream_.string()).exit_code,
              0);
  }

  // The smallest limit (to kStep) at which the program starts at all:
  // below it the loader cannot map its libraries (exit 127).
  long startUpLimit(const std::string& binary) {
    long low = 8 * 1024, high = 4L * 1024 * 1024;  // KB
    const fs::path folder = out_ / "start";
    fs::create_directories(folder);
    while (high - low > kStep) {
      const long middle = (low + high) / 2;
      (runLimited(folder, binary, "--help", middle).exit_code == 0 ? high : low) = middle;
    }
    return high;
  }

  // Runs `args` at limits rising by kStep from where `binary` starts, until
  // it succeeds (at most kMostPoints runs); checks each run.
  // `cache`: a folder of the run's whose whole files may stay (the
  // benchmark's stream cache: a stream recorded before the failure is whole).
  void sweep(const std::string& binary, const std::string& args, const std::string& cache = "") {
    const long start = startUpLimit(binary);
    for (int point = 0; point < kMostPoints; ++point) {
      const long limit = start + point * kStep;
      const fs::path folder = out_ / ("at" + std::to_string(limit));
      fs::create_directories(folder);
      const Outcome outcome = runLimited(folder, binary, args, limit);
      const std::string where = args + " under ulimit -v " + std::to_string(limit) + ": ";
      EXPECT_TRUE(outcome.exit_code <= 2) << where << "exit " << outcome.exit_code << "\n"
                                          << outcome.stderr_text;
      EXPECT_FALSE(holdsTemporaries(folder)) << where << "temporaries left";
      if (outcome.exit_code == 0) {
        fs::remove_all(folder);
        return;
      }
      if (outcome.exit_code == 1) {
        EXPECT_NE(outcome.stderr_text.find("out of memory"), std::string::npos)
            << where << outcome.stderr_text;
        // --max-memory is advised only where it was not given.
        if (args.find("--max-memory") != std::string::npos) {
          EXPECT_EQ(outcome.stderr_text.find("a --max-memory"), std::string::npos)
              << where << outcome.stderr_text;
        }
      }
      for (const fs::path& file : filesLeft(folder)) {
        if (!cache.empty() && file.parent_path() == folder / cache) continue;
        ADD_FAILURE() << where << "exit " << outcome.exit_code << " left " << file.string();
      }
      fs::remove_all(folder);
    }
    ADD_FAILURE() << args << ": still failing " << kMostPoints * kStep / 1024
                  << " MB above its start-up";
  }

  static constexpr long kStep = 4 * 1024;  // KB
  // 400 MB above start-up: a program that renders maps OSMesa and its LLVM
  // (about 150 MB) only at its first renderer (render/osmesa_library.h).
  static constexpr int kMostPoints = 100;
  fs::path stream_;
};

#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)

TEST_F(MemoryCliTest, RunUnderAShrinkingAddressSpaceExitsOutOfMemoryNeverBySignal) {
  sweep(OVERLAP_BINARY, "run --objects 300 --frames 3 --out o");
}

TEST_F(MemoryCliTest, RecordUnderAShrinkingAddressSpaceExitsOutOfMemoryNeverBySignal) {
  sweep(OVERLAP_BINARY, "record --objects 300 --frames 3 --out r.aabbs");
}

TEST_F(MemoryCliTest, PairsUnderAShrinkingAddressSpaceExitsOutOfMemoryNeverBySignal) {
  sweep(OVERLAP_BINARY, "pairs --algo cpusap --input " + stream_.string());
}

TEST_F(MemoryCliTest, PairsWithAMemoryLimitUnderAShrinkingAddressSpaceNeverAdvisesOne) {
  sweep(OVERLAP_BINARY, "pairs --algo bf --max-memory 100000 --input " + stream_.string());
}

TEST_F(MemoryCliTest, GenerateUnderAShrinkingAddressSpaceExitsOutOfMemoryNeverBySignal) {
  sweep(OVERLAP_BINARY, "generate --objects 300 --frames 3 --out g.aabbs");
}

TEST_F(MemoryCliTest, CaptureUnderAShrinkingAddressSpaceExitsOutOfMemoryNeverBySignal) {
  sweep(OVERLAP_BINARY, "capture --objects 300 --keyframes 0,2 --capture-size 320x240 --out c");
}

TEST_F(MemoryCliTest, LatencyUnderAShrinkingAddressSpaceExitsOutOfMemoryNeverBySignal) {
  sweep(OVERLAP_BINARY, "latency --objects 300 --frames 3 --algo bf,sap");
}

TEST_F(MemoryCliTest, TheBenchmarkUnderAShrinkingAddressSpaceExitsOutOfMemoryNeverBySignal) {
  sweep(OVERLAP_BENCH_BINARY,
        "--algos bf,sap,cpusap --warmup 0 --repeats 1 --input " + stream_.string() + " --out b");
}

// Recording its own streams, the benchmark builds a PhysicsWorld; the
// streams it recorded whole before memory ran out stay in its cache.
TEST_F(MemoryCliTest, TheBenchmarkRecordingItsStreamsUnderAShrinkingAddressSpaceNeverSignals) {
  sweep(OVERLAP_BENCH_BINARY,
        "--objects 50 --big-objects 300 --record-frames 2 --algos bvh --warmup 0 --repeats 1 "
        "--streams s --out b",
        "s");
}

#endif

}  // namespace
}  // namespace overlap::testing
