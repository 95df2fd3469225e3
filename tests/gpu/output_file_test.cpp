// gpu/base/output_file.h: temporaries, write-through, symlinks, run folders.
#include "gpu/base/output_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>

#include "tests/scratch_path.h"

namespace overlap {
namespace {

namespace fs = std::filesystem;

std::string textOf(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

int entries(const fs::path& folder) {
  int count = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(folder)) ++count;
  return count;
}

class OutputFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = overlap::testing::scratchPath(
        std::string("output_") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(folder_);
    fs::create_directories(folder_);
  }
  void TearDown() override { fs::remove_all(folder_); }
  fs::path folder_;
};

TEST_F(OutputFileTest, TheNameHoldsTheOldFileUntilPublishedAndEachWriterHasItsOwnTemporary) {
  const fs::path path = folder_ / "a.txt";
  std::ofstream(path) << "old";
  OutputFile first(path);
  OutputFile second(path);
  first.write("first");
  second.write("second");
  EXPECT_EQ(textOf(path), "old");
  EXPECT_EQ(entries(folder_), 3);  // the old file and two temporaries
  first.commit();
  EXPECT_EQ(textOf(path), "first");
  second.commit();
  EXPECT_EQ(textOf(path), "second");
  EXPECT_EQ(entries(folder_), 1);
}

TEST_F(OutputFileTest, AnUnpublishedOutputLeavesNothing) {
  {
    OutputFile file(folder_ / "never.txt");
    file.write("lost");
  }
  EXPECT_EQ(entries(folder_), 0);
}

TEST_F(OutputFileTest, SymlinksAreFollowedAndFifosWrittenThrough) {
  std::ofstream(folder_ / "target") << "old";
  fs::create_symlink("target", folder_ / "link");
  writeFileAtomically(folder_ / "link", "new");
  EXPECT_TRUE(fs::is_symlink(folder_ / "link"));
  EXPECT_EQ(textOf(folder_ / "target"), "new");

  const fs::path fifo = folder_ / "fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string received;
  std::thread reader([&] { received = textOf(fifo); });
  writeFileAtomically(fifo, "through");
  reader.join();
  EXPECT_EQ(received, "through");
  EXPECT_TRUE(fs::is_fifo(fifo));
}

TEST_F(OutputFileTest, FailedWritesAndBadNamesAreNamed) {
  try {
    writeFileAtomically("/dev/full", "x");
    FAIL() << "wrote to /dev/full";
  } catch (const OutputError& error) {
    EXPECT_NE(std::string(error.what()).find("/dev/full: cannot write"), std::string::npos)
        << error.what();
  }
  EXPECT_EQ(outputFileProblem(""), "the name is empty");
  EXPECT_NE(outputFileProblem(folder_ / "new/"), "");
  EXPECT_EQ(outputFileProblem(folder_), "is a directory, not a file");
  EXPECT_EQ(outputFileProblem(folder_ / "sub" / "new.txt"), "");
  EXPECT_TRUE(fs::is_directory(folder_ / "sub"));
}

TEST_F(OutputFileTest, AFolderReplacesOnlyWhatTheLastRunWrote) {
  fs::create_directories(folder_ / "frames");
  std::ofstream(folder_ / "mine.txt") << "mine";
  {
    OutputFolder run(folder_);
    run.open(folder_ / "a.txt").write("1");
    run.open(folder_ / "frames" / "x.png").write("1");
    run.commit();
  }
  OutputFolder second(folder_);
  second.open(folder_ / "a.txt").write("2");
  EXPECT_EQ(textOf(folder_ / "a.txt"), "1");  // nothing moves before commit()
  second.commit();
  EXPECT_EQ(textOf(folder_ / "a.txt"), "2");
  EXPECT_FALSE(fs::exists(folder_ / "frames" / "x.png"));
  EXPECT_EQ(textOf(folder_ / "mine.txt"), "mine");
}

}  // namespace
}  // namespace overlap
