// gpu/base/output_file.h: temporaries, write-through, symlinks, run folders.
#include "gpu/base/output_file.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>

#include "gpu/base/interrupt.h"
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

// A pseudo-terminal's master side, ready to open its slave; -1 where the
// machine has none.
int openPtyMaster() {
  const int master = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (master >= 0 && (::grantpt(master) != 0 || ::unlockpt(master) != 0)) {
    ::close(master);
    return -1;
  }
  return master;
}

// A terminal that passes every byte as it is (no newline turned into two).
void makeRaw(int terminal) {
  termios raw{};
  ::tcgetattr(terminal, &raw);
  ::cfmakeraw(&raw);
  ::tcsetattr(terminal, TCSANOW, &raw);
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
  // A folder anyone may write, where only a file's owner (or root) may
  // rename or remove it, as /tmp.
  fs::path stickyFolder() const {
    const fs::path sticky = folder_ / "sticky";
    fs::create_directory(sticky);
    EXPECT_EQ(::chmod(sticky.c_str(), 01777), 0);
    return sticky;
  }
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
  {
    OutputFolder run(folder_ / "new" / "run");
    run.open(folder_ / "new" / "run" / "a.txt").write("lost");
    run.open(folder_ / "new" / "run" / "frames" / "b.png").write("lost");
  }
  EXPECT_EQ(entries(folder_), 0);  // the folders made for them too
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
  EXPECT_FALSE(fs::exists(folder_ / "sub"));  // checking creates nothing
  EXPECT_NE(outputFileProblem(folder_ / "new" / "."), "");
  EXPECT_NE(outputFileProblem(folder_ / ".."), "");
  fs::create_symlink("loop", folder_ / "loop");
  EXPECT_NE(outputFileProblem(folder_ / "loop").find("symbolic links"), std::string::npos);
  EXPECT_NE(outputFileProblem(folder_ / std::string(256, 'n')).find("longer than 255"),
            std::string::npos);
  EXPECT_EQ(entries(folder_), 1);  // the loop alone
}

TEST_F(OutputFileTest, ANameAsLongAsTheFolderTakesIsWritten) {
  const fs::path longest = folder_ / std::string(255, 'n');
  EXPECT_EQ(outputFileProblem(longest), "");
  writeFileAtomically(longest, "long");
  EXPECT_EQ(textOf(longest), "long");
  EXPECT_EQ(entries(folder_), 1);
  writeFileAtomically(folder_ / "sub" / "new.txt", "made");  // its folder made when opened
  EXPECT_EQ(textOf(folder_ / "sub" / "new.txt"), "made");
}

TEST_F(OutputFileTest, ManifestEntriesAreOneLineEachAndReadBackWhole) {
  for (const std::string name : {"sound.wav", "a\nb", "two\nlines", "#hash", "\\", "cr\r"}) {
    const std::string line = escapeManifestEntry(name);
    EXPECT_EQ(line.find('\n'), std::string::npos) << line;
    EXPECT_EQ(unescapeManifestEntry(line), name) << line;
  }
  EXPECT_EQ(unescapeManifestEntry("a\\"), std::nullopt);
  EXPECT_EQ(unescapeManifestEntry("a\\x"), std::nullopt);
}

TEST_F(OutputFileTest, AManifestNotInThisFormatRemovesNothing) {
  std::ofstream(folder_ / "mine.txt") << "mine";
  std::ofstream(folder_ / OutputFolder::kManifestName) << "# an older manifest\nmine.txt\n";
  OutputFolder run(folder_);
  run.open(folder_ / "a.txt").write("1");
  run.commit();
  EXPECT_EQ(textOf(folder_ / "mine.txt"), "mine");
}

TEST_F(OutputFileTest, TwoOutputsOfOneRunCannotBeOneFile) {
  OutputFolder run(folder_ / "run");
  EXPECT_EQ(run.declare(folder_ / "run" / "summary.json"), "");
  EXPECT_NE(run.declare(folder_ / "run" / ".." / "run" / "summary.json").find("is also"),
            std::string::npos);
  EXPECT_NE(run.declare(folder_ / "run" / OutputFolder::kManifestName).find("is also"),
            std::string::npos);
  EXPECT_EQ(run.declare(folder_ / "run" / "frames.csv"), "");
  EXPECT_FALSE(fs::exists(folder_ / "run"));
  run.open(folder_ / "run" / "frames.csv");
  EXPECT_THROW(run.open(folder_ / "run" / "frames.csv"), OutputError);
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

// Two names of one file are one output however a link and ".." spell it:
// "link/.." is the parent of the link's target, as the kernel has it.
TEST_F(OutputFileTest, NamesThroughALinkAndDotDotAreTheFileTheKernelReaches) {
  fs::create_directories(folder_ / "run" / "sub");
  fs::create_directory_symlink(folder_ / "run" / "sub", folder_ / "link");
  OutputFolder run(folder_ / "run");
  EXPECT_EQ(run.declare(folder_ / "run" / "frames.csv"), "");
  EXPECT_NE(run.declare(folder_ / "link" / ".." / "frames.csv").find("is also"), std::string::npos);
  EXPECT_NE(run.declare(folder_ / "link" / "." / ".." / "frames.csv").find("is also"),
            std::string::npos);
  // Beside the link itself is elsewhere: folder_/frames.csv.
  EXPECT_EQ(run.declare(folder_ / "frames.csv"), "");
  EXPECT_NE(run.declare(folder_ / "link" / ".." / ".." / "frames.csv").find("is also"),
            std::string::npos);
}

// A signal that came before commit() publishes nothing: the old file stays
// and no temporary is left, for a run folder as for one file.
TEST_F(OutputFileTest, ASignalBeforeTheCommitPublishesNothing) {
  std::ofstream(folder_ / "a.txt") << "old";
  interrupt_detail::received.store(SIGINT);
  {
    OutputFolder run(folder_);
    run.open(folder_ / "a.txt").write("new");
    EXPECT_THROW(run.commit(), Interrupted);
    OutputFile file(folder_ / "b.txt");
    file.write("new");
    EXPECT_THROW(file.commit(), Interrupted);
  }
  interrupt_detail::received.store(0);
  EXPECT_EQ(textOf(folder_ / "a.txt"), "old");
  EXPECT_EQ(entries(folder_), 1);
}

// A rename that fails at the commit leaves a manifest listing only files
// that are there: the last run's and those already published.
TEST_F(OutputFileTest, AFailedCommitListsOnlyTheFilesThatAreThere) {
  {
    OutputFolder run(folder_);
    run.open(folder_ / "old.txt").write("1");
    run.commit();
  }
  OutputFolder run(folder_);
  run.open(folder_ / "a.txt").write("2");
  run.open(folder_ / "b.txt").write("2");
  fs::create_directory(folder_ / "b.txt");  // b.txt cannot be renamed into place
  EXPECT_THROW(run.commit(), OutputError);
  const std::string manifest = textOf(folder_ / OutputFolder::kManifestName);
  EXPECT_NE(manifest.find("\na.txt\n"), std::string::npos) << manifest;
  EXPECT_NE(manifest.find("\nold.txt\n"), std::string::npos) << manifest;
  EXPECT_EQ(manifest.find("b.txt"), std::string::npos) << manifest;
}

// /dev/stdout, /dev/fd/N and /proc/self/fd/N are written to the descriptor
// itself: an unlinked file gets the bytes (no "NAME (deleted)" made beside
// it), a file opened for append keeps what it held, and a descriptor open
// for reading only is refused before any work.
TEST_F(OutputFileTest, AnOpenDescriptorNamedThroughItsLinksIsWrittenToItself) {
  const fs::path unlinked = folder_ / "unlinked.out";
  const int hidden = ::open(unlinked.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  ASSERT_GE(hidden, 0);
  ::unlink(unlinked.c_str());
  writeFileAtomically("/proc/self/fd/" + std::to_string(hidden), "bytes");
  EXPECT_EQ(::lseek(hidden, 0, SEEK_END), 5);
  EXPECT_EQ(entries(folder_), 0) << "a file made beside the unlinked one";
  ::close(hidden);

  const fs::path log = folder_ / "log.txt";
  std::ofstream(log) << "earlier\n";
  const int appended = ::open(log.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
  ASSERT_GE(appended, 0);
  fs::create_symlink("/dev/fd/" + std::to_string(appended), folder_ / "link");
  EXPECT_EQ(outputFileProblem(folder_ / "link"), "");
  writeFileAtomically(folder_ / "link", "later\n");
  ::close(appended);
  EXPECT_EQ(textOf(log), "earlier\nlater\n");

  const int reading = ::open(log.c_str(), O_RDONLY | O_CLOEXEC);
  ASSERT_GE(reading, 0);
  const fs::path name = "/dev/fd/" + std::to_string(reading);
  EXPECT_NE(outputFileProblem(name).find("not open for writing"), std::string::npos);
  EXPECT_THROW(OutputFile{name}, OutputError);
  ::close(reading);
  EXPECT_EQ(textOf(log), "earlier\nlater\n");
}

// A descriptor that is a regular file not opened for append is patched
// where the output began (a WAV's header sizes); one opened for append is
// streamed.
TEST_F(OutputFileTest, ADescriptorToAFileIsRewrittenWhereTheOutputBegan) {
  const fs::path path = folder_ / "f.bin";
  std::ofstream(path) << "hello";
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::lseek(fd, 0, SEEK_END), 5);
  {
    OutputFile out("/dev/fd/" + std::to_string(fd));
    ASSERT_TRUE(out.rewritable());
    out.write("abcdef");
    out.rewrite(0, "XY");
    out.commit();
  }
  ::close(fd);
  EXPECT_EQ(textOf(path), "helloXYcdef");
  const int appended = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
  OutputFile streamed("/dev/fd/" + std::to_string(appended));
  EXPECT_FALSE(streamed.rewritable());
  EXPECT_THROW(streamed.rewrite(0, "Z"), OutputError);
  ::close(appended);
}

// A socket cannot be opened as a file: refused before any work, never
// waited on for a reader that cannot come.
TEST_F(OutputFileTest, ASocketIsRefusedNotWaitedOn) {
  const fs::path socket_path = folder_ / "s.sock";
  const int listener = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  ASSERT_GE(listener, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::snprintf(address.sun_path, sizeof(address.sun_path), "%s", socket_path.c_str());
  ASSERT_EQ(::bind(listener, reinterpret_cast<const sockaddr*>(&address), sizeof(address)), 0);
  EXPECT_NE(outputFileProblem(socket_path).find("is a socket"), std::string::npos);
  EXPECT_THROW(OutputFile{socket_path}, OutputError);
  ::close(listener);
}

// A replaced file keeps its permissions and owner but never a set-ID bit: the
// new file is this program's.
TEST_F(OutputFileTest, AReplacedFileKeepsItsModeAndOwnerButNoSetIdBit) {
  const fs::path path = folder_ / "own.txt";
  std::ofstream(path) << "old";
  ASSERT_EQ(::chmod(path.c_str(), 06750), 0);
  const bool root = ::geteuid() == 0;
  if (root) {
    ASSERT_EQ(::chown(path.c_str(), 1234, 1234), 0);
  }
  writeFileAtomically(path, "new");
  struct stat info {};
  ASSERT_EQ(::stat(path.c_str(), &info), 0);
  EXPECT_EQ(info.st_mode & 07777, 0750u);
  if (root) {
    EXPECT_EQ(info.st_uid, 1234u);
    EXPECT_EQ(info.st_gid, 1234u);
  }
  EXPECT_EQ(textOf(path), "new");
}

// A folder another subcommand's manifest names is refused, so a capture never
// removes a run's measurements (or a run a capture's pictures); a manifest of
// the older format, which names no writer, is taken as before.
TEST_F(OutputFileTest, AFolderOfAnotherSubcommandsOutputsIsRefused) {
  {
    OutputFolder run(folder_, "run");
    ASSERT_EQ(run.declare(folder_ / "frames.csv"), "");
    run.open(folder_ / "frames.csv").write("frame\n");
    run.commit();
  }
  OutputFolder capture(folder_, "capture");
  const std::string problem = capture.declare(folder_ / "scene4_frame0000.png");
  EXPECT_NE(problem.find("holds the outputs of `overlap run`"), std::string::npos) << problem;
  OutputFolder again(folder_, "run");
  EXPECT_EQ(again.declare(folder_ / "frames.csv"), "");

  // A list written before the writer line: taken only when each entry is one
  // the subcommand writes.
  std::ofstream(folder_ / OutputFolder::kManifestName)
      << OutputFolder::kManifestHeader << "\nframes.csv\n";
  const auto keyframe = [](const std::string& entry) { return entry.ends_with(".png"); };
  OutputFolder older(folder_, "capture");
  older.takeOlderListsWhen(keyframe);
  EXPECT_NE(older.declare(folder_ / "scene4_frame0000.png").find("another subcommand"),
            std::string::npos);
  OutputFolder older_run(folder_, "run");
  older_run.takeOlderListsWhen([&](const std::string& entry) { return !keyframe(entry); });
  EXPECT_EQ(older_run.declare(folder_ / "frames.csv"), "");
  std::ofstream(folder_ / OutputFolder::kManifestName)
      << OutputFolder::kManifestHeader << "\nscene4_frame0000.png\n";
  OutputFolder older_capture(folder_, "capture");
  older_capture.takeOlderListsWhen(keyframe);
  EXPECT_EQ(older_capture.declare(folder_ / "scene4_frame0001.png"), "");
}

// A folder inside a run folder whose list names files in it (a run's
// frames/) is that run's, not another output folder's.
TEST_F(OutputFileTest, AFolderHoldingAnotherRunsOutputsIsRefused) {
  fs::create_directories(folder_ / "frames");
  {
    OutputFolder run(folder_, "run");
    ASSERT_EQ(run.declare(folder_ / "frames" / "scene4_frame0000.png"), "");
    run.open(folder_ / "frames" / "scene4_frame0000.png").write("png");
    run.commit();
  }
  OutputFolder inside(folder_ / "frames", "capture");
  const std::string problem = inside.declare(folder_ / "frames" / "scene4_frame0000.png");
  EXPECT_NE(problem.find("holds outputs of the run folder"), std::string::npos) << problem;
  fs::create_directories(folder_ / "other");
  OutputFolder beside(folder_ / "other", "capture");
  EXPECT_EQ(beside.declare(folder_ / "other" / "scene4_frame0000.png"), "");
}

// An output that is the program's own standard error would have its
// messages spliced in: refused however it is named (a descriptor, a FIFO's
// path); a terminal or /dev/null takes both.
TEST_F(OutputFileTest, AnOutputThatIsStandardErrorIsRefused) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const fs::path file = folder_ / "both.txt";
  EXPECT_EXIT(
      {
        const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
        ::dup2(fd, STDERR_FILENO);
        const bool refused =
            outputFileProblem("/dev/fd/" + std::to_string(fd)).find("is also standard error") !=
            std::string::npos;
        // A FIFO named by its path is the same stream.
        const fs::path fifo = folder_ / "both.fifo";
        const int both = ::mkfifo(fifo.c_str(), 0600) == 0
                             ? ::open(fifo.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC)
                             : -1;
        ::dup2(both, STDERR_FILENO);
        const bool fifo_refused = both >= 0 && outputFileProblem(fifo).find(
                                                   "is also standard error") != std::string::npos;
        const int null = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
        ::dup2(null, STDERR_FILENO);
        const bool null_taken = outputFileProblem("/dev/fd/" + std::to_string(null)).empty();
        std::exit(refused && fifo_refused && null_taken ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

// Bytes written through a descriptor stay written: a stop says so rather
// than that the outputs hold what they held before.
TEST_F(OutputFileTest, AStopNamesWhatWasWrittenAsItWent) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const fs::path log = folder_ / "log.txt";
  EXPECT_EXIT(
      {
        const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
        OutputFile out("/dev/fd/" + std::to_string(fd));
        out.write("part of a stream");
        std::exit(reportInterrupted("test", Interrupted(SIGTERM, "frame 3")) == 128 + SIGTERM ? 0
                                                                                              : 1);
      },
      ::testing::ExitedWithCode(0),
      "already sent, and staying sent: /dev/fd/[0-9]+ \\(written as it went\\)");
}

// Another user's file in a sticky folder (/tmp) cannot be renamed over but by
// root: refused before any work, not after it.
TEST_F(OutputFileTest, AnotherUsersFileInAStickyFolderIsRefusedBeforeAnyWork) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to make another user's file";
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const fs::path sticky = stickyFolder();
  const fs::path theirs = sticky / "theirs.txt";
  std::ofstream(theirs) << "theirs";
  ASSERT_EQ(::chmod(theirs.c_str(), 0666), 0);
  ASSERT_EQ(::chown(theirs.c_str(), 4321, 4321), 0);
  EXPECT_EXIT(
      {
        if (::setgid(1234) != 0 || ::setuid(1234) != 0) std::exit(2);
        const std::string problem = outputFileProblem(theirs);
        std::exit(problem.find("sticky folder") != std::string::npos &&
                          outputFileProblem(sticky / "mine.txt").empty()
                      ? 0
                      : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

// A terminal no one reads blocks a write, and the stop signal may reach
// another thread than the writer's: the write still stops, however the
// terminal is named (its path, a descriptor).  A reader that reads, slowly,
// gets every byte, through a descriptor left non-blocking too.
TEST_F(OutputFileTest, AWriteToATerminalNoOneReadsStopsAtASignal) {
  const int master = openPtyMaster();
  if (master < 0) GTEST_SKIP() << "no pseudo-terminal here";
  const std::string terminal = ::ptsname(master);
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  for (const bool by_descriptor : {false, true}) {
    EXPECT_EXIT(
        {
          ::alarm(20);  // a write that never stops fails the test, not the suite
          const int slave = ::open(terminal.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC);
          const fs::path name = by_descriptor ? "/dev/fd/" + std::to_string(slave) : terminal;
          std::atomic<bool> stopped = false;
          std::thread writer([&] {
            try {
              OutputFile out(name);
              out.write(std::string(std::size_t{1} << 20, 'x'));
            } catch (const Interrupted&) {
              stopped = true;
            }
          });
          std::this_thread::sleep_for(std::chrono::milliseconds(300));
          interrupt_detail::received.store(SIGTERM);
          writer.join();
          std::exit(stopped ? 0 : 1);
        },
        ::testing::ExitedWithCode(0), "");
  }
  EXPECT_EXIT(
      {
        ::alarm(20);
        const int slave = ::open(terminal.c_str(), O_WRONLY | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
        makeRaw(slave);
        const std::size_t size = std::size_t{1} << 18;
        std::size_t got = 0;
        std::thread reader([&] {
          char buffer[3000];
          while (got < size) {
            pollfd ready{master, POLLIN, 0};
            if (::poll(&ready, 1, 2000) <= 0) return;
            const ssize_t read = ::read(master, buffer, sizeof(buffer));
            if (read <= 0) return;
            got += static_cast<std::size_t>(read);
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
          }
        });
        OutputFile out("/dev/fd/" + std::to_string(slave));
        out.write(std::string(size, 'x'));
        out.finish();
        reader.join();
        std::exit(got == size ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
  ::close(master);
}

// A pty's master side, reopened, would be a new pty no one reads (/dev/ptmx):
// named through its descriptor, it is written through that descriptor, and
// the terminal on its other side gets every byte.
TEST_F(OutputFileTest, APtyMasterNamedThroughItsDescriptorReachesItsTerminal) {
  const int master = openPtyMaster();
  if (master < 0) GTEST_SKIP() << "no pseudo-terminal here";
  const int terminal = ::open(::ptsname(master), O_RDONLY | O_NOCTTY | O_CLOEXEC);
  ASSERT_GE(terminal, 0);
  makeRaw(terminal);
  const std::string bytes(2000, 'x');
  {
    OutputFile out("/dev/fd/" + std::to_string(master));
    out.write(bytes);
    out.finish();
  }
  std::string got;
  char buffer[4096];
  for (pollfd ready{terminal, POLLIN, 0};
       got.size() < bytes.size() && ::poll(&ready, 1, 2000) > 0;) {
    const ssize_t read = ::read(terminal, buffer, sizeof(buffer));
    if (read <= 0) break;
    got.append(buffer, static_cast<std::size_t>(read));
  }
  EXPECT_EQ(got, bytes);
  ::close(terminal);
  ::close(master);
}

// A device is written as it is, whatever its poll() says (/dev/random never
// says it has room), by name and through a descriptor; one that no open can
// serve is refused before any work: /dev/ptmx (each open a new terminal no
// one reads), /dev/tty without a terminal (no device), never waited for.
TEST_F(OutputFileTest, DevicesAreWrittenAsTheyAreOrRefusedBeforeAnyWork) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        ::alarm(20);  // a write or an open that waits for good fails the test
        bool written = true;
        if (::access("/dev/random", W_OK) == 0) {
          OutputFile by_name("/dev/random");
          by_name.write(std::string(1 << 16, 'x'));
          by_name.finish();
          const int fd = ::open("/dev/random", O_WRONLY | O_CLOEXEC);
          OutputFile by_descriptor("/dev/fd/" + std::to_string(fd));
          by_descriptor.write(std::string(1 << 16, 'x'));
          by_descriptor.finish();
          written = by_name.writtenThrough() && by_descriptor.writtenThrough();
        }
        const bool ptmx_refused =
            !fs::exists("/dev/ptmx") ||
            outputFileProblem("/dev/ptmx").find("pty multiplexer") != std::string::npos;
        ::setsid();  // no controlling terminal from here
        bool tty_refused = true;
        if (fs::exists("/dev/tty")) {
          tty_refused = outputFileProblem("/dev/tty").find("cannot be opened") != std::string::npos;
          try {
            OutputFile tty("/dev/tty");
            tty_refused = false;
          } catch (const OutputError&) {
          }
        }
        std::exit(written && ptmx_refused && tty_refused ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

// A folder between a run folder and an output that holds a list of its own
// (a capture's in the run's frames/) is not the run's: refused before any
// work, as the capture is refused inside the run's frames/.
TEST_F(OutputFileTest, AFolderInsideHoldingAnotherListIsRefused) {
  {
    OutputFolder capture(folder_ / "frames", "capture");
    ASSERT_EQ(capture.declare(folder_ / "frames" / "scene4_frame0000.png"), "");
    fs::create_directories(folder_ / "frames");
    capture.open(folder_ / "frames" / "scene4_frame0000.png").write("capture's");
    capture.commit();
  }
  OutputFolder run(folder_, "run");
  const std::string problem = run.declare(folder_ / "frames" / "scene4_frame0000.png");
  EXPECT_NE(problem.find("holds the outputs of `overlap capture`"), std::string::npos) << problem;
  EXPECT_EQ(textOf(folder_ / "frames" / "scene4_frame0000.png"), "capture's");
}

// The lists above a folder are read only where this user wrote them and
// only as large as a list a run writes: another user's list in a shared
// folder, or a file of gigabytes, neither refuses nor stalls a run below.
TEST_F(OutputFileTest, ListsAboveAreTheUsersOwnAndBounded) {
  const fs::path inner = folder_ / "res";
  const fs::path list = folder_ / OutputFolder::kManifestName;
  std::ofstream(list) << OutputFolder::kManifestHeader << "\n\\writer run\nres/frames.csv\n";
  EXPECT_NE(OutputFolder(inner).declare(inner / "frames.csv").find("holds outputs of the run"),
            std::string::npos);
  ASSERT_EQ(::truncate(list.c_str(), off_t{1} << 27), 0);  // sparse: no room taken
  EXPECT_EQ(OutputFolder(inner).declare(inner / "frames.csv"), "");
  if (::geteuid() != 0) return;
  ASSERT_EQ(::truncate(list.c_str(), 0), 0);
  std::ofstream(list) << OutputFolder::kManifestHeader << "\n\\writer run\nres/frames.csv\n";
  ASSERT_EQ(::chown(list.c_str(), 5678, 5678), 0);
  EXPECT_EQ(OutputFolder(inner).declare(inner / "frames.csv"), "");
}

// The next run removes or replaces every file the last one listed: one it
// cannot (another user's in a sticky folder) is refused before any work,
// never kept unlisted at the end.
TEST_F(OutputFileTest, ALastRunsFileThisUserCannotRemoveIsRefusedBeforeAnyWork) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to make another user's file";
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const fs::path sticky = stickyFolder();
  {
    OutputFolder run(sticky);
    ASSERT_EQ(run.declare(sticky / "frames.csv"), "");
    ASSERT_EQ(run.declare(sticky / "sound.wav"), "");
    run.open(sticky / "frames.csv").write("frame\n");
    run.open(sticky / "sound.wav").write("RIFF");
    run.commit();
  }
  for (const char* name : {"frames.csv", OutputFolder::kManifestName}) {
    ASSERT_EQ(::chown((sticky / name).c_str(), 1234, 1234), 0);
  }
  EXPECT_EXIT(
      {
        if (::setgid(1234) != 0 || ::setuid(1234) != 0) std::exit(2);
        const std::string problem = OutputFolder(sticky).declare(sticky / "frames.csv");
        std::exit(problem.find("sound.wav") != std::string::npos &&
                          problem.find("sticky folder") != std::string::npos
                      ? 0
                      : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

}  // namespace
}  // namespace overlap
