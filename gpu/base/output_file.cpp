#include "gpu/base/output_file.h"

#include <fcntl.h>
#include <limits.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <functional>
#include <mutex>
#include <optional>
#include <sstream>
#include <system_error>

#include "gpu/base/interrupt.h"

namespace overlap {
namespace {

namespace fs = std::filesystem;

std::string lastError() {
  return std::strerror(errno);
}

// `path` with its symlinks followed (at most 40, as the kernel does) up to
// the first name `stop` takes; a dangling link gives the name it points to,
// where the file will be made.
template <typename Stop>
fs::path walkLinks(fs::path path, const Stop& stop) {
  for (int hop = 0; hop < 40; ++hop) {
    if (stop(path)) return path;
    std::error_code error;
    if (!fs::is_symlink(fs::symlink_status(path, error))) return path;
    const fs::path link = fs::read_symlink(path, error);
    if (error) return path;
    path = link.is_absolute() ? link : path.parent_path() / link;
  }
  return path;
}

fs::path followLinks(fs::path path) {
  return walkLinks(std::move(path), [](const fs::path&) { return false; });
}

constexpr int kNoDescriptor = -1;
constexpr int kOthersDescriptor = -2;

// Plain decimal digits as the kernel writes a number: no sign, no leading 0.
bool allDigits(const std::string& text) {
  return !text.empty() && text.size() <= 9 && (text.size() == 1 || text[0] != '0') &&
         std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); });
}

// The descriptor `path` names when its folder is a process's descriptor
// folder (/proc/PID/fd or /proc/PID/task/TID/fd, however reached: /dev/fd,
// /proc/self, /proc/thread-self): this process's descriptor, or
// kOthersDescriptor for another process's; kNoDescriptor otherwise.
int descriptorEntry(const fs::path& path) {
  const std::string name = path.filename().string();
  if (!allDigits(name)) return kNoDescriptor;
  std::error_code error;
  const fs::path folder = fs::canonical(path.parent_path(), error);
  if (error || folder.filename() != "fd") return kNoDescriptor;
  fs::path process = folder.parent_path();  // /proc/PID or /proc/PID/task/TID
  if (process.parent_path().filename() == "task") process = process.parent_path().parent_path();
  if (process.parent_path() != "/proc" || !allDigits(process.filename().string())) {
    return kNoDescriptor;
  }
  if (process.filename() != std::to_string(::getpid())) return kOthersDescriptor;
  return std::stoi(name);
}

// The open descriptor `path` reaches through its links (/dev/stdout,
// /dev/fd/N, /proc/self/fd/N, a user's link to one), or kNoDescriptor, or
// kOthersDescriptor.  The kernel's link of a descriptor names no path the
// program could write (an unlinked file, a memfd, "pipe:[N]"), and
// reopening the file it is would lose the caller's append and offset: such
// an output is written to the descriptor itself.
int descriptorReached(fs::path path) {
  int fd = kNoDescriptor;
  walkLinks(std::move(path), [&fd](const fs::path& name) {
    fd = descriptorEntry(name);
    return fd != kNoDescriptor;
  });
  return fd;
}

// "" unless an output that is written through (`output` its stat) is the
// file standard error writes to, where the program's messages go: they
// would be spliced into it.  A terminal or /dev/null takes both.
std::string messagesProblem(const struct stat& output) {
  struct stat messages {};
  if (::fstat(STDERR_FILENO, &messages) == 0 && output.st_dev == messages.st_dev &&
      output.st_ino == messages.st_ino && !S_ISCHR(output.st_mode)) {
    return "is also standard error, where the program's messages go: send them elsewhere "
           "(2>FILE) or name the file itself";
  }
  return "";
}

constexpr const char* kNewDeviceAtEachOpen =
    "is the pty multiplexer: each open makes a new terminal, which no one reads";

// True for a device whose every open makes a new one: the pty multiplexer
// (/dev/ptmx, and devpts' own ptmx), whose descriptors are pty masters.
bool makesANewDeviceAtEachOpen(dev_t device) {
  constexpr unsigned kTtyAuxMajor = 5;  // Linux's devices.txt: /dev/tty, /dev/console, /dev/ptmx
  constexpr unsigned kPtmxMinor = 2;
  return major(device) == kTtyAuxMajor && minor(device) == kPtmxMinor;
}

// "" when descriptor `fd` (descriptorReached's) can take an output.
std::string descriptorProblem(int fd) {
  if (fd == kOthersDescriptor) {
    return "is another process's open file (/proc/PID/fd): name the file itself";
  }
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags < 0) return "names descriptor " + std::to_string(fd) + ", which is not open";
  if ((flags & O_ACCMODE) == O_RDONLY || (flags & O_PATH) != 0) {
    return "names descriptor " + std::to_string(fd) +
           ", which is not open for writing (closed at the start, a folder, or read-only)";
  }
  struct stat output {};
  return ::fstat(fd, &output) == 0 ? messagesProblem(output) : "";
}

fs::path folderOf(const fs::path& file) {
  return file.has_parent_path() ? file.parent_path() : fs::path(".");
}

// "" unless `file` (`info` its stat) is another user's in a sticky folder
// not this user's, which the kernel lets no one but root rename over.
std::string stickyReplaceProblem(const fs::path& file, const struct stat& info) {
  if (::geteuid() == 0 || info.st_uid == ::geteuid()) return "";
  struct stat folder {};
  if (::stat(folderOf(file).c_str(), &folder) != 0 || (folder.st_mode & S_ISVTX) == 0 ||
      folder.st_uid == ::geteuid()) {
    return "";
  }
  return "is user " + std::to_string(info.st_uid) + "'s file in a sticky folder (" +
         folderOf(file).string() + "), which this user cannot replace or remove";
}

// The longest name a folder takes (NAME_MAX where the file system does not say).
std::size_t longestName(const fs::path& folder) {
  const long most = ::pathconf(folder.c_str(), _PC_NAME_MAX);
  return most > 0 ? static_cast<std::size_t>(most) : NAME_MAX;
}

// A temporary's name: ".NAME.overlap-PID-XXXXXX", the PID its writer's, so a
// later run can tell a dead writer's temporary from a live one's.
constexpr std::string_view kTemporaryMark = ".overlap-";
constexpr std::size_t kUniqueChars = 6;  // mkostemp's XXXXXX

// The pattern of `target`'s temporary beside it: NAME is cut short where the
// whole would be longer than a name may be, so every name that is legal can
// be written.
std::string temporaryPattern(const fs::path& target) {
  std::string suffix(kTemporaryMark);
  suffix += std::to_string(::getpid()) + "-" + std::string(kUniqueChars, 'X');
  const std::string name = target.filename().string();
  const std::size_t most = longestName(folderOf(target));
  const std::size_t room = most > suffix.size() + 2 ? most - 1 - suffix.size() : 1;
  std::string hidden = ".";  // appended, not "." + name: GCC 12 warns falsely (-Wrestrict)
  hidden += name.substr(0, room);
  hidden += suffix;
  return (folderOf(target) / hidden).string();
}

// Empty when a file can be made in the existing folder `folder`, else why
// not.  Tried, not inferred from the permissions (root passes `access` on
// /proc): a hidden file is made and removed at once.
std::string trialProblem(const fs::path& folder) {
  std::string trial = (folder / ".overlap-check-XXXXXX").string();
  const int fd = ::mkostemp(trial.data(), O_CLOEXEC);
  if (fd < 0) return lastError();
  ::close(fd);
  ::unlink(trial.c_str());
  return {};
}

// Empty when a file can be made in `folder`, which may not exist yet (then
// its nearest existing folder must be writable and every name to be made
// short enough), else why not.  Leaves nothing behind.
std::string folderWritableProblem(const fs::path& folder) {
  struct stat info {};
  if (::stat(folder.c_str(), &info) == 0) {
    if (!S_ISDIR(info.st_mode)) return "is not a folder";
    const std::string problem = trialProblem(folder);
    return problem.empty() ? "" : "no file can be made in the folder: " + problem;
  }
  if (errno != ENOENT) return "cannot be reached: " + lastError();
  const fs::path existing = nearestExisting(folder);
  if (!fs::is_directory(existing)) return existing.string() + " is not a folder";
  if (const std::string problem = trialProblem(existing); !problem.empty()) {
    return "cannot create it: " + existing.string() + ": no file can be made there: " + problem;
  }
  for (const fs::path& part : folder) {
    if (part.string().size() > longestName(existing)) {
      return "cannot create it: the name " + part.string() + " is longer than " +
             std::to_string(longestName(existing)) + " bytes";
    }
  }
  return {};
}

// The mode a new file gets: 0666 less the umask, read once.
mode_t newFileMode() {
  static const mode_t mode = [] {
    const mode_t mask = ::umask(0);
    ::umask(mask);
    return static_cast<mode_t>(0666 & ~mask);
  }();
  return mode;
}

void syncFolder(const fs::path& folder) {
  const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;  // the renames are done; durability is best effort here
  ::fsync(fd);
  ::close(fd);
}

// Wakes a thread's blocking write every tenth of a second while it lives:
// a timer aimed at the thread sends it a signal whose handler does nothing,
// installed without SA_RESTART, so a write blocked on a device returns
// EINTR (or what it wrote) and its loop can look for a stop.  A device
// cannot be polled for room instead: its poll() may never say so
// (/dev/random), or say so for less than a write takes (a terminal).
class WakeupTimer {
 public:
  WakeupTimer() {
    static const int wakeup = [] {
      const int number = SIGRTMIN + 7;  // no library here uses it
      struct sigaction action {};
      action.sa_handler = [](int) {};
      sigemptyset(&action.sa_mask);
      action.sa_flags = 0;
      ::sigaction(number, &action, nullptr);
      return number;
    }();
    sigset_t only{};
    sigemptyset(&only);
    sigaddset(&only, wakeup);
    ::pthread_sigmask(SIG_UNBLOCK, &only, &saved_mask_);
    sigevent event{};
    event.sigev_notify = SIGEV_THREAD_ID;
    event.sigev_signo = wakeup;
    event._sigev_un._tid = ::gettid();  // glibc 2.36 names no sigev_notify_thread_id
    armed_ = ::timer_create(CLOCK_MONOTONIC, &event, &timer_) == 0;
    const itimerspec every{{0, kTenthNs}, {0, kTenthNs}};
    if (armed_) ::timer_settime(timer_, 0, &every, nullptr);
  }
  ~WakeupTimer() {
    if (armed_) ::timer_delete(timer_);  // a wakeup still pending lands here, harmlessly
    ::pthread_sigmask(SIG_SETMASK, &saved_mask_, nullptr);
  }
  WakeupTimer(const WakeupTimer&) = delete;
  WakeupTimer& operator=(const WakeupTimer&) = delete;

 private:
  static constexpr long kTenthNs = 100'000'000;
  timer_t timer_{};
  bool armed_ = false;
  sigset_t saved_mask_{};
};

// Writes every byte; `name` is the output's, for the message of a signal
// that stops a write blocked on a slow reader.  Anything but a regular file
// may wait on its reader, who may never read, and the stop signal may reach
// another thread than the writer's, so no EINTR would come (a blocked write
// in the sound job kept a run from stopping).  So a pipe, FIFO or socket is
// written a pipe buffer at a time, each once poll() says it has room; a
// device (a terminal) is written under a WakeupTimer; a non-blocking
// descriptor's EAGAIN waits in poll(); and each wait looks for a stop
// signal every tenth of a second.
void writeAll(int fd, std::string_view bytes, const std::string& name,
              const std::function<void()>& on_error) {
  struct stat info {};
  const bool known = ::fstat(fd, &info) == 0;
  const bool pollable = known && (S_ISFIFO(info.st_mode) || S_ISSOCK(info.st_mode));
  const bool device = known && !pollable && !S_ISREG(info.st_mode);
  std::optional<WakeupTimer> wakeups;
  if (device) wakeups.emplace();
  // The stop's message is built only when a signal came.
  const auto stopIfAsked = [&name] {
    if (pendingInterrupt() != 0) stopIfInterrupted("the write to " + name);
  };
  // False when the tenth of a second ended with no room (or a signal).
  const auto waitForRoom = [fd, &stopIfAsked] {
    pollfd room{fd, POLLOUT, 0};
    const int ready = ::poll(&room, 1, 100);
    const bool interrupted = ready < 0 && errno == EINTR;
    stopIfAsked();
    return ready != 0 && !interrupted;
  };
  while (!bytes.empty()) {
    std::size_t chunk = bytes.size();
    if (pollable) {
      if (!waitForRoom()) continue;
      chunk = std::min<std::size_t>(chunk, PIPE_BUF);
    }
    const ssize_t wrote = ::write(fd, bytes.data(), chunk);
    if (wrote < 0 && errno == EINTR) {
      stopIfAsked();
      continue;
    }
    if (wrote < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      waitForRoom();
      continue;
    }
    if (wrote <= 0) {
      if (wrote == 0) errno = EIO;
      on_error();
    }
    bytes.remove_prefix(static_cast<std::size_t>(wrote));
    if (device) stopIfAsked();
  }
}

// The PID in a name of the temporaries' pattern, else 0.
pid_t temporaryOwner(std::string_view name) {
  if (name.size() < kUniqueChars + 1 || name[0] != '.') return 0;
  const std::string_view unique = name.substr(name.size() - kUniqueChars);
  const bool unique_ok = std::all_of(unique.begin(), unique.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0;
  });
  if (!unique_ok || name[name.size() - kUniqueChars - 1] != '-') return 0;
  const std::string_view named =
      name.substr(0, name.size() - kUniqueChars - 1);  // ".NAME.overlap-PID"
  const std::size_t mark = named.rfind(kTemporaryMark);
  if (mark == std::string_view::npos || mark < 2) return 0;  // "." and at least one character
  const std::string_view pid = named.substr(mark + kTemporaryMark.size());
  const bool pid_ok =
      !pid.empty() && pid.size() <= 9 &&
      std::all_of(pid.begin(), pid.end(), [](char c) { return c >= '0' && c <= '9'; });
  return pid_ok ? static_cast<pid_t>(std::stoi(std::string(pid))) : 0;
}

// A temporary is stale when its writer is gone: no process has its PID
// (ESRCH; a live process of another user answers EPERM and is kept) and no
// one holds the lock every writer keeps on its temporary while it writes
// (a writer in another PID namespace).
bool staleTemporary(const fs::path& path, pid_t owner) {
  if (owner == ::getpid() || ::kill(owner, 0) == 0 || errno != ESRCH) return false;
  const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return false;
  struct stat info {};
  const bool stale = ::fstat(fd, &info) == 0 && S_ISREG(info.st_mode) &&
                     info.st_uid == ::geteuid() && ::flock(fd, LOCK_EX | LOCK_NB) == 0;
  ::close(fd);
  return stale;
}

// Removes, once per folder per process, the temporaries that dead writers
// of this program left in `folder` (a run killed by SIGKILL or a second
// signal).  Only names of the temporaries' pattern are looked at.
void removeStaleTemporaries(const fs::path& folder) {
  static std::mutex mutex;
  static std::set<std::string> cleared;
  std::error_code error;
  const fs::path key = fs::weakly_canonical(folder, error);
  {
    const std::lock_guard lock(mutex);
    if (!cleared.insert(key.string()).second) return;
  }
  for (fs::directory_iterator entry(folder, error), end; !error && entry != end;
       entry.increment(error)) {
    const pid_t owner = temporaryOwner(entry->path().filename().string());
    if (owner > 0 && staleTemporary(entry->path(), owner)) ::unlink(entry->path().c_str());
  }
}

// Opens a device, FIFO or socket to write through.  A FIFO without a reader
// is waited for (saying so after a second, stopped by a signal), not opened
// blocking: a blocking open() cannot be told apart from a hang.
int openWrittenThrough(const fs::path& target, const fs::path& shown) {
  int fd = -1;
  waitUntil(
      [&](int timeout_ms) {
        fd = ::open(target.c_str(), O_WRONLY | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
        if (fd >= 0 || errno != ENXIO) return true;
        // ENXIO: a FIFO with no reader yet, or a device that is not there
        // (/dev/tty without a terminal), which no wait brings.
        struct stat info {};
        if (::stat(target.c_str(), &info) != 0 || !S_ISFIFO(info.st_mode)) return true;
        ::poll(nullptr, 0, timeout_ms);
        return false;
      },
      "waiting for a reader to open " + shown.string(),
      "the wait for a reader of " + shown.string());
  // Blocking again: writeAll waits for room its own way.
  if (fd >= 0) ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  return fd;
}

// A manifest entry: a plain relative path that stays inside the folder.
bool safeRelative(const fs::path& path) {
  if (path.empty() || path.is_absolute()) return false;
  for (const fs::path& part : path) {
    if (part == ".." || part == ".") return false;
  }
  return true;
}

}  // namespace

fs::path nearestExisting(fs::path path) {
  std::error_code error;
  while (!path.empty() && !fs::exists(fs::symlink_status(path, error))) path = path.parent_path();
  return path.empty() ? fs::path(".") : path;
}

std::string escapeManifestEntry(std::string_view name) {
  std::string line;
  for (const char c : name) {
    if (c == '\\') {
      line += "\\\\";
    } else if (c == '\n') {
      line += "\\n";
    } else if (c == '\r') {
      line += "\\r";
    } else {
      line += c;
    }
  }
  return line;
}

std::optional<std::string> unescapeManifestEntry(std::string_view line) {
  std::string name;
  for (std::size_t i = 0; i < line.size(); ++i) {
    if (line[i] != '\\') {
      name += line[i];
      continue;
    }
    if (++i == line.size()) return std::nullopt;
    switch (line[i]) {
      case '\\':
        name += '\\';
        break;
      case 'n':
        name += '\n';
        break;
      case 'r':
        name += '\r';
        break;
      default:
        return std::nullopt;
    }
  }
  return name;
}

std::string outputNameProblem(const fs::path& file) {
  if (file.empty()) return "the name is empty";
  if (!file.has_filename()) return "names a folder (it ends in '/'), not a file";
  if (file.filename() == "." || file.filename() == "..") {
    return "names a folder (it ends in '" + file.filename().string() + "'), not a file";
  }
  return {};
}

fs::path outputTarget(const fs::path& path) {
  return followLinks(path);
}

int descriptorOfOutput(const fs::path& path) {
  const int fd = descriptorReached(path);
  return fd >= 0 ? fd : -1;
}

std::string outputFolderProblem(const fs::path& folder) {
  if (folder.empty()) return "the name is empty";
  return folderWritableProblem(folder);
}

std::string outputFileProblem(const fs::path& file) {
  return outputFileProblemIn(file, nullptr);
}

namespace {

// "" when a device or FIFO (`info` its stat) can be written through.  A
// device is opened once to try it (/dev/tty without a terminal is no
// device: ENXIO), never kept: the output opens it again.
std::string writtenThroughProblem(const fs::path& file, const struct stat& info) {
  if (S_ISSOCK(info.st_mode)) return "is a socket, which no program can open as a file";
  if (::access(file.c_str(), W_OK) != 0) return "not writable: " + lastError();
  if (S_ISCHR(info.st_mode)) {
    if (makesANewDeviceAtEachOpen(info.st_rdev)) return kNewDeviceAtEachOpen;
    const int trial = ::open(file.c_str(), O_WRONLY | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (trial < 0) return "cannot be opened: " + lastError();
    ::close(trial);
  }
  return messagesProblem(info);
}

}  // namespace

std::string outputFileProblemIn(const fs::path& file, std::set<fs::path>* writable_folders) {
  if (std::string problem = outputNameProblem(file); !problem.empty()) return problem;
  // An open descriptor is written to itself, wherever it leads.
  if (const int fd = descriptorReached(file); fd != kNoDescriptor) return descriptorProblem(fd);
  struct stat info {};
  // A device or FIFO is written through the name as given.
  if (::stat(file.c_str(), &info) == 0 && !S_ISREG(info.st_mode) && !S_ISDIR(info.st_mode)) {
    return writtenThroughProblem(file, info);
  }
  const fs::path target = followLinks(file);
  const fs::path folder = folderOf(target);
  const std::size_t most = longestName(nearestExisting(folder));
  if (target.filename().string().size() > most) {
    return "the name " + target.filename().string().substr(0, 16) + "... is longer than " +
           std::to_string(most) + " bytes";
  }
  if (::stat(target.c_str(), &info) == 0) {
    if (S_ISDIR(info.st_mode)) return "is a directory, not a file";
    if (!S_ISREG(info.st_mode)) return writtenThroughProblem(target, info);
    if (std::string problem = stickyReplaceProblem(target, info); !problem.empty()) return problem;
  } else if (errno != ENOENT) {
    return "cannot be reached: " + lastError();  // a symlink loop, a file as a folder
  }
  if (writable_folders != nullptr && writable_folders->contains(folder)) return {};
  if (const std::string problem = folderWritableProblem(folder); !problem.empty()) {
    return "its folder " + folder.string() + ": " + problem;
  }
  if (writable_folders != nullptr) writable_folders->insert(folder);
  return {};
}

OutputFile::OutputFile(fs::path path, FinalLink link)
    : path_(std::move(path)),
      target_(link == FinalLink::kFollow ? followLinks(path_) : path_),
      replace_link_(link == FinalLink::kReplace) {
  if (path_.empty()) fail("the name is empty");
  if (!replace_link_) {
    if (const int descriptor = descriptorReached(path_); descriptor != kNoDescriptor) {
      if (const std::string problem = descriptorProblem(descriptor); !problem.empty()) {
        fail(problem);
      }
      // The caller's own description, never the file reopened: a device
      // may reopen as another (/dev/tty is the opener's terminal, a pty's
      // master side reopens /dev/ptmx, a new pty).
      struct stat opened {};
      fd_ = ::fcntl(descriptor, F_DUPFD_CLOEXEC, 0);
      if (fd_ < 0) fail("cannot use descriptor " + std::to_string(descriptor) + ": " + lastError());
      // A regular file not appended to can be patched where this output began.
      const off_t start = ::lseek(fd_, 0, SEEK_CUR);
      rewrite_base_ = ::fstat(fd_, &opened) == 0 && S_ISREG(opened.st_mode) &&
                              (::fcntl(fd_, F_GETFL) & O_APPEND) == 0 && start >= 0
                          ? start
                          : -1;
      return;
    }
  }
  struct stat info {};
  const bool exists =
      (replace_link_ ? ::lstat(path_.c_str(), &info) : ::stat(path_.c_str(), &info)) == 0;
  if (exists && S_ISDIR(info.st_mode)) fail("is a directory, not a file");
  if (exists && S_ISSOCK(info.st_mode)) fail("is a socket, which no program can open as a file");
  if (exists && !S_ISREG(info.st_mode) && !S_ISLNK(info.st_mode)) {
    if (S_ISCHR(info.st_mode) && makesANewDeviceAtEachOpen(info.st_rdev)) {
      fail(kNewDeviceAtEachOpen);
    }
    fd_ = openWrittenThrough(path_, path_);  // the kernel follows what followLinks cannot
    if (fd_ < 0) fail("cannot open for writing: " + lastError());
    struct stat opened {};
    if (::fstat(fd_, &opened) == 0) {
      if (const std::string problem = messagesProblem(opened); !problem.empty()) {
        ::close(fd_);
        fd_ = -1;
        fail(problem);
      }
    }
    rewrite_base_ = -1;
    return;
  }
  // The checks before any work created no folder: the first output made
  // there does, and removes them again if it is never published.
  std::error_code error;
  for (fs::path folder = folderOf(target_); !folder.empty() && !fs::exists(folder, error);
       folder = folder.parent_path()) {
    created_folders_.push_back(folder);  // deepest first
  }
  fs::create_directories(folderOf(target_), error);
  if (error) fail("cannot create its folder: " + error.message());
  removeStaleTemporaries(folderOf(target_));
  std::string name = temporaryPattern(target_);
  fd_ = ::mkostemp(name.data(), O_CLOEXEC);  // O_CREAT | O_EXCL: a name of its own
  if (fd_ < 0) fail("cannot create a temporary file beside it: " + lastError());
  ::flock(fd_, LOCK_SH);  // while it is open, no other run takes it for stale
  temporary_ = name;
  // A replaced file keeps its owner (where this process may give it) and
  // its permissions, never a set-ID bit: the new file is this program's,
  // and a write by anyone but the owner clears those bits too.  A new file
  // gets the umask's mode.
  if (exists && S_ISREG(info.st_mode)) {
    if (info.st_uid != ::geteuid() || info.st_gid != ::getegid()) {
      [[maybe_unused]] const int kept = ::fchown(fd_, info.st_uid, info.st_gid);
    }
    ::fchmod(fd_, info.st_mode & 0777);
  } else {
    ::fchmod(fd_, newFileMode());
  }
}

OutputFile::OutputFile(OutputFile&& other) noexcept
    : path_(std::move(other.path_)),
      target_(std::move(other.target_)),
      replace_link_(other.replace_link_),
      temporary_(std::move(other.temporary_)),
      fd_(other.fd_),
      finished_(other.finished_),
      published_(other.published_),
      noted_written_through_(other.noted_written_through_),
      rewrite_base_(other.rewrite_base_),
      created_folders_(std::move(other.created_folders_)) {
  other.fd_ = -1;
  other.temporary_.clear();
  other.published_ = true;
  other.created_folders_.clear();
}

OutputFile::~OutputFile() {
  if (fd_ >= 0) ::close(fd_);
  if (published_) return;
  if (!temporary_.empty()) ::unlink(temporary_.c_str());
  for (const fs::path& folder : created_folders_) ::rmdir(folder.c_str());  // only if empty
}

void OutputFile::fail(const std::string& what) const {
  throw OutputError(path_.string() + ": " + what);
}

void OutputFile::write(std::string_view bytes) {
  if (fd_ < 0) fail("written after it was finished");
  // What is written through stays written, whatever stops the run.
  if (writtenThrough() && !noted_written_through_ && !bytes.empty() && path_ != "/dev/null") {
    noteWrittenThrough(path_.string());
    noted_written_through_ = true;
  }
  writeAll(fd_, bytes, path_.string(), [this] { fail("cannot write: " + lastError()); });
}

bool OutputFile::rewritable() const {
  // Another holder of a shared descriptor may have set O_APPEND since it
  // was opened, and a write at an offset would then land at the end.
  return rewrite_base_ >= 0 && fd_ >= 0 && (::fcntl(fd_, F_GETFL) & O_APPEND) == 0;
}

void OutputFile::rewrite(std::uint64_t offset, std::string_view bytes) {
  if (!rewritable()) fail("cannot rewrite what is streamed, appended to or finished");
  while (!bytes.empty()) {
    const ssize_t wrote =
        ::pwrite(fd_, bytes.data(), bytes.size(), static_cast<off_t>(rewrite_base_ + offset));
    if (wrote < 0 && errno == EINTR) continue;
    if (wrote <= 0) fail("cannot write: " + lastError());
    bytes.remove_prefix(static_cast<std::size_t>(wrote));
    offset += static_cast<std::uint64_t>(wrote);
  }
}

void OutputFile::finish() {
  if (finished_) return;
  // Devices and FIFOs have nothing to sync (fsync fails on a FIFO).
  if (!writtenThrough() && ::fsync(fd_) != 0) fail("cannot write to disk: " + lastError());
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) fail("cannot finish writing: " + lastError());
  finished_ = true;
}

void OutputFile::publish() {
  if (!finished_) fail("published before it was finished");
  if (published_) return;
  if (!writtenThrough()) {
    struct stat info {};
    if (::lstat(target_.c_str(), &info) == 0 && !S_ISREG(info.st_mode) &&
        !(replace_link_ && S_ISLNK(info.st_mode))) {
      fail("is no longer a regular file; not replaced");
    }
    if (::rename(temporary_.c_str(), target_.c_str()) != 0) {
      fail("cannot rename the finished file into place: " + lastError());
    }
    syncFolder(folderOf(target_));
  }
  published_ = true;
}

void OutputFile::commit() {
  finish();
  stopIfInterrupted("the publication of " + path_.string());
  publish();
}

void writeFileAtomically(const fs::path& path, std::string_view contents) {
  OutputFile file(path);
  file.write(contents);
  file.commit();
}

void writeStandardOutput(std::string_view bytes) {
  writeAll(STDOUT_FILENO, bytes, "standard output",
           [] { throw OutputError("standard output: cannot write: " + lastError()); });
}

OutputFolder::~OutputFolder() {
  // Last opened first: a folder an earlier output made is empty by its turn.
  while (!files_.empty()) files_.pop_back();
}

namespace {

// An open folder (O_PATH: nothing is read through it), closed when done.
struct PathHandle {
  explicit PathHandle(int descriptor) : fd(descriptor) {}
  ~PathHandle() {
    if (fd >= 0) ::close(fd);
  }
  PathHandle(const PathHandle&) = delete;
  PathHandle& operator=(const PathHandle&) = delete;
  void reset(int descriptor) {
    if (fd >= 0) ::close(fd);
    fd = descriptor;
  }
  int fd;
};

// The kernel's own path of an open folder (what /proc/self/fd names), or
// empty where /proc is not mounted.
std::string kernelPath(int fd) {
  char link[PATH_MAX + 1];
  const std::string self = "/proc/self/fd/" + std::to_string(fd);
  const ssize_t got = ::readlink(self.c_str(), link, PATH_MAX);
  if (got <= 0 || link[0] != '/') return {};
  return std::string(link, static_cast<std::size_t>(got));
}

bool sameFile(const struct stat& a, const struct stat& b) {
  return a.st_dev == b.st_dev && a.st_ino == b.st_ino;
}

// Where a name lands: the folder holding it, as the kernel resolves it.
struct Resolved {
  std::string folder;       // absolute, no link in the part that exists
  std::string passed_link;  // see resolve(); empty if none
};

// The folder holding `path`'s name, resolved one part at a time by the
// kernel (openat follows each link from where it stands, so "link/.." is
// the parent of the link's target, as for open()); parts not made yet are
// kept as named, a ".." among them taking back the one before.  With
// `run` (the run folder, when it exists), `passed_link` is the first link
// met as named once the walk has entered the run folder.
Resolved resolve(const fs::path& path, const struct stat* run = nullptr) {
  Resolved resolved;
  PathHandle at(::open(path.is_absolute() ? "/" : ".", O_PATH | O_DIRECTORY | O_CLOEXEC));
  std::vector<std::string> missing;
  fs::path named;
  int depth_in_run = -1;  // parts below the run folder; -1: not inside it
  for (const fs::path& part : folderOf(path)) {
    const std::string text = part.string();
    named /= part;
    if (text.empty() || text == "." || part == part.root_path()) continue;
    if (!missing.empty() || at.fd < 0) {
      if (text == ".." && !missing.empty()) {
        missing.pop_back();
      } else {
        missing.push_back(text);
      }
      continue;
    }
    struct stat here {};
    if (run != nullptr && ::fstat(at.fd, &here) == 0 && sameFile(here, *run)) depth_in_run = 0;
    if (depth_in_run >= 0 && text != ".." && resolved.passed_link.empty()) {
      struct stat info {};
      if (::fstatat(at.fd, text.c_str(), &info, AT_SYMLINK_NOFOLLOW) == 0 &&
          S_ISLNK(info.st_mode)) {
        resolved.passed_link = named.string();
      }
    }
    const int next = ::openat(at.fd, text.c_str(), O_PATH | O_DIRECTORY | O_CLOEXEC);
    if (next < 0) {
      missing.push_back(text);  // not made yet (or not a folder: its check says so)
      continue;
    }
    at.reset(next);
    if (depth_in_run >= 0) depth_in_run += text == ".." ? -1 : 1;
  }
  fs::path folder;
  if (at.fd >= 0) folder = kernelPath(at.fd);
  if (folder.empty()) {  // no /proc: the library's resolution of the same folder
    std::error_code error;
    folder = fs::weakly_canonical(fs::absolute(folderOf(path), error), error);
    missing.clear();
  }
  for (const std::string& part : missing) folder /= part;
  resolved.folder = folder.string();
  return resolved;
}

}  // namespace

namespace {

constexpr std::string_view kWriterMark = "\\writer ";  // no escaped name starts so

// A list's text read: the subcommand its writer line names ("" for none:
// an older list) and every entry that unescapes.  A text without this
// format's first line (an older format, or not ours) lists nothing.
struct ManifestList {
  std::string writer;
  std::vector<std::string> entries;
};

ManifestList parseManifest(std::string_view text) {
  ManifestList list;
  const auto next_line = [&text]() -> std::optional<std::string_view> {
    if (text.empty()) return std::nullopt;
    const std::size_t end = std::min(text.find('\n'), text.size());
    const std::string_view line = text.substr(0, end);
    text.remove_prefix(std::min(end + 1, text.size()));
    return line;
  };
  if (next_line() != std::optional<std::string_view>(OutputFolder::kManifestHeader)) return list;
  for (bool second = true; const std::optional<std::string_view> line = next_line();
       second = false) {
    if (line->starts_with(kWriterMark)) {
      if (second) list.writer = line->substr(kWriterMark.size());
      continue;
    }
    if (std::optional<std::string> entry = unescapeManifestEntry(*line)) {
      list.entries.push_back(std::move(*entry));
    }
  }
  return list;
}

// The entries a run may act on: plain relative paths that stay inside.
std::set<std::string> safeEntries(const ManifestList& list) {
  std::set<std::string> entries;
  for (const std::string& entry : list.entries) {
    if (safeRelative(entry)) entries.insert(entry);
  }
  return entries;
}

}  // namespace

OutputFolder::OutputFolder(fs::path folder, std::string writer)
    : folder_(std::move(folder)), writer_(std::move(writer)) {
  folder_identity_ = resolve(folder_ / "name").folder;
  const fs::path manifest = folder_ / kManifestName;
  declared_.emplace(identity(manifest), manifest.string());
}

// What makes two names one output: the file they reach, however spelled
// ("r/x", "./r/x", "r//x", "/abs/r/x", "r/new/../x", "link/../r/x"): the
// folder holding the name as the kernel resolves it (resolve()), plus the
// name.  Inside the run folder the name's own link is not followed (it is
// replaced); elsewhere it is, as the file written is its target.
std::string OutputFolder::identity(const fs::path& path) const {
  if (const std::optional<fs::path> relative = inside(path)) {
    return (fs::path(folder_identity_) / *relative).string();
  }
  const fs::path target = followLinks(path);
  if (!target.has_filename()) return resolve(target).folder;
  return (fs::path(resolve(target).folder) / target.filename()).string();
}

std::optional<fs::path> OutputFolder::inside(const fs::path& path) const {
  if (!path.has_filename()) return std::nullopt;
  const std::string folder = resolve(path).folder;
  std::string relative = path.filename().string();
  if (folder != folder_identity_) {
    const std::string above =
        folder_identity_.back() == '/' ? folder_identity_ : folder_identity_ + "/";
    if (folder.compare(0, above.size(), above) != 0) return std::nullopt;
    relative = folder.substr(above.size()) + "/" + relative;
  }
  if (!safeRelative(relative)) return std::nullopt;
  return fs::path(relative);
}

std::string OutputFolder::linkProblem(const fs::path& path) const {
  struct stat run {};
  if (::stat(folder_.c_str(), &run) != 0) return {};  // not made yet: nothing in it is a link
  const Resolved resolved = resolve(path, &run);
  if (resolved.passed_link.empty()) return {};
  return resolved.passed_link +
         " is a symbolic link: a run folder's outputs are written inside it, never through a link";
}

namespace {

// Two identities where the first is a folder above the second.
bool isAbove(const std::string& folder, const std::string& below) {
  return below.size() > folder.size() && below.compare(0, folder.size(), folder) == 0 &&
         (folder.back() == '/' || below[folder.size()] == '/');
}

}  // namespace

std::string OutputFolder::declare(const fs::path& path) {
  // The folder's list is a regular file (or a link, replaced), never
  // something a run would hang on or fail at the end: a FIFO, a folder.
  const fs::path manifest = folder_ / kManifestName;
  struct stat info {};
  if (::lstat(manifest.c_str(), &info) == 0) {
    if (!S_ISREG(info.st_mode) && !S_ISLNK(info.st_mode)) {
      return manifest.string() + ", the list of the run folder's outputs, is not a regular file";
    }
    if (S_ISREG(info.st_mode)) {
      if (std::string problem = stickyReplaceProblem(manifest, info); !problem.empty()) {
        return manifest.string() + ", the list of the run folder's outputs, " + problem;
      }
    }
  }
  // Another subcommand's outputs are not this run's to replace.
  if (!writer_checked_) {
    const ManifestList previous = parseManifest(manifestText());
    std::string whose;  // the other subcommand, when the list is another's
    if (!previous.writer.empty()) {
      if (previous.writer != writer_) whose = "`overlap " + previous.writer + "`";
    } else if (older_list_is_mine_) {
      const std::set<std::string> entries = safeEntries(previous);
      if (!std::all_of(entries.begin(), entries.end(), older_list_is_mine_)) {
        whose = "another subcommand";
      }
    }
    if (!whose.empty()) {
      return "its folder " + folder_.string() + " holds the outputs of " + whose + " (listed in " +
             kManifestName + "), which this " + writer_ + " would remove: choose another folder";
    }
    if (std::string problem = enclosingRunProblem(); !problem.empty()) return problem;
    if (std::string problem = previousOutputsProblem(safeEntries(previous)); !problem.empty()) {
      return problem;
    }
    writer_checked_ = true;
  }
  // Links first: the checks below try the folder by making a file there.
  if (std::string problem = linkProblem(path); !problem.empty()) return problem;
  if (std::string problem = outputFileProblemIn(path, &writable_folders_); !problem.empty()) {
    return problem;
  }
  if (const std::optional<fs::path> relative = inside(path)) {
    if (std::string problem = innerListProblem(*relative); !problem.empty()) return problem;
  }
  const std::string id = identity(path);
  if (id == folder_identity_ || isAbove(id, folder_identity_)) {
    return "is the run's folder " + folder_.string() + " or a folder above it, not a file";
  }
  // The map is in name order: what is below `id` follows "id/" at once.
  const std::string below = id + "/";
  if (const auto next = declared_.lower_bound(below);
      next != declared_.end() && next->first.compare(0, below.size(), below) == 0) {
    return "is the folder of another output of this run (" + next->second + "), not a file";
  }
  for (fs::path folder = fs::path(id).parent_path(); folder.has_relative_path();
       folder = folder.parent_path()) {
    if (const auto above = declared_.find(folder.string()); above != declared_.end()) {
      return "would be inside another output of this run (" + above->second + "), which is a file";
    }
  }
  const auto [where, added] = declared_.emplace(id, path.string());
  if (!added)
    return "is also an output of this run (" + where->second + "): one file cannot hold both";
  return {};
}

OutputFile& OutputFolder::open(const fs::path& path) {
  const std::optional<fs::path> relative = inside(path);
  const fs::path opened = relative ? folder_ / *relative : path;
  const FinalLink link = relative ? FinalLink::kReplace : FinalLink::kFollow;
  if (!opened_.insert(identity(path)).second) {
    throw OutputError(path.string() + ": opened twice as one run's output");
  }
  if (const std::string problem = linkProblem(opened); !problem.empty()) {
    throw OutputError(path.string() + ": " + problem);
  }
  files_.push_back(std::make_unique<OutputFile>(opened, link));
  listed_.push_back(relative ? relative->generic_string() : std::string());
  if (relative) inside_.insert(listed_.back());
  return *files_.back();
}

namespace {

// The run folder, opened to reach its entries without following links.
struct FolderHandle {
  explicit FolderHandle(const fs::path& folder)
      : fd(::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC)) {}
  ~FolderHandle() {
    if (fd >= 0) ::close(fd);
  }
  FolderHandle(const FolderHandle&) = delete;
  FolderHandle& operator=(const FolderHandle&) = delete;
  int fd;
};

// Opens the folder holding `relative` inside the folder `root` (an open
// descriptor), one part at a time, refusing any part that is a symlink
// (O_NOFOLLOW): what is reached never leaves the folder.  -1 if it cannot.
int openParentInside(int root, const fs::path& relative) {
  int at = ::dup(root);
  for (const fs::path& part : relative.parent_path()) {
    if (at < 0) return -1;
    const int next = ::openat(at, part.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    ::close(at);
    at = next;
  }
  return at;
}

// Removes the regular file `relative` inside `folder`, reached without
// leaving the folder (no link followed, the file's own included); true if
// it was removed.
bool removeInside(int folder, const fs::path& relative) {
  const int parent = openParentInside(folder, relative);
  if (parent < 0) return false;
  struct stat info {};
  const std::string name = relative.filename().string();
  const bool removed = ::fstatat(parent, name.c_str(), &info, AT_SYMLINK_NOFOLLOW) == 0 &&
                       S_ISREG(info.st_mode) && ::unlinkat(parent, name.c_str(), 0) == 0;
  ::close(parent);
  return removed;
}

// The longest list a run writes: a million frames' keyframes, named.
constexpr off_t kMostManifestBytes = off_t{64} << 20;

// Whose lists are read (OutputFolder::manifestText, enclosingRunProblem).
enum class ListOwner { kAnyone, kThisUser };

// The list of outputs in `folder`, read without following a link ("" for
// none): one larger than any list a run writes is none of this program's,
// and kThisUser takes only the lists this user wrote.
std::string manifestTextIn(const fs::path& folder_path, ListOwner owner = ListOwner::kAnyone) {
  const FolderHandle folder(folder_path);
  if (folder.fd < 0) return "";
  // Never through a link: a manifest someone linked elsewhere lists nothing.
  const int fd = ::openat(folder.fd, OutputFolder::kManifestName,
                          O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return "";
  std::string text;
  struct stat info {};
  if (::fstat(fd, &info) == 0 && S_ISREG(info.st_mode) && info.st_size <= kMostManifestBytes &&
      (owner == ListOwner::kAnyone || info.st_uid == ::geteuid())) {
    char buffer[65536];
    ssize_t got = 0;
    while (text.size() <= static_cast<std::size_t>(kMostManifestBytes) &&
           (got = ::read(fd, buffer, sizeof(buffer))) > 0) {
      text.append(buffer, static_cast<std::size_t>(got));
    }
    if (text.size() > static_cast<std::size_t>(kMostManifestBytes)) text.clear();  // grew meanwhile
  }
  ::close(fd);
  return text;
}

}  // namespace

std::string OutputFolder::manifestText() const {
  return manifestTextIn(folder_);
}

std::string OutputFolder::enclosingRunProblem() const {
  const fs::path folder = folder_identity_;
  if (!folder.is_absolute()) return "";
  for (fs::path above = folder.parent_path(); above.has_relative_path();
       above = above.parent_path()) {
    const std::string inside = folder.lexically_relative(above).string() + "/";
    // Another user's list in a shared folder (/tmp) never refuses this one.
    const std::string text = manifestTextIn(above, ListOwner::kThisUser);
    for (const std::string& entry : parseManifest(text).entries) {
      if (entry.starts_with(inside)) {
        return "its folder " + folder_.string() + " holds outputs of the run folder " +
               above.string() + " (" + entry + "), which this " + writer_ +
               " would replace: choose another folder";
      }
    }
  }
  return "";
}

std::string OutputFolder::innerListProblem(const fs::path& relative) const {
  fs::path inner = folder_;
  for (const fs::path& part : relative.parent_path()) {
    inner /= part;
    struct stat info {};
    if (::lstat((inner / kManifestName).c_str(), &info) != 0) continue;
    const std::string writer = parseManifest(manifestTextIn(inner)).writer;
    return "its folder " + inner.string() + " holds the outputs of " +
           (writer.empty() ? std::string("another run") : "`overlap " + writer + "`") +
           " (listed in " + kManifestName + "), which this " + writer_ +
           " would replace: choose another folder";
  }
  return "";
}

std::string OutputFolder::previousOutputsProblem(const std::set<std::string>& previous) const {
  std::set<fs::path> inner_folders;
  for (const std::string& entry : previous) {
    const fs::path file = folder_ / entry;
    struct stat info {};
    if (::lstat(file.c_str(), &info) != 0 || !S_ISREG(info.st_mode)) continue;
    // The next run removes or replaces every listed file: one it cannot is
    // refused now, not kept unlisted at the end.
    if (std::string problem = stickyReplaceProblem(file, info); !problem.empty()) {
      return file.string() + ", an output of the last " + writer_ + " here, " + problem;
    }
    if (inner_folders.insert(fs::path(entry).parent_path()).second) {
      if (std::string problem = innerListProblem(entry); !problem.empty()) return problem;
    }
  }
  return "";
}

std::set<std::string> OutputFolder::previousOutputs() const {
  // Files the program did not write stay: only what the list names is acted on.
  return safeEntries(parseManifest(manifestText()));
}

void OutputFolder::writeManifest(const std::set<std::string>& entries) const {
  std::string text = std::string(kManifestHeader) + '\n';
  text += std::string(kWriterMark) + escapeManifestEntry(writer_) + '\n';
  for (const std::string& entry : entries) text += escapeManifestEntry(entry) + '\n';
  OutputFile manifest(folder_ / kManifestName, FinalLink::kReplace);
  manifest.write(text);
  // Never stopped by a signal: commit() writes it past the last moment one
  // can stop the run, where a stop would name outputs already replaced.
  manifest.finish();
  manifest.publish();
}

std::vector<std::string> OutputFolder::commit() {
  for (const auto& file : files_) file->finish();
  // The last moment a signal can stop the run whole: past here every rename
  // is done, and a stop in between would leave a mix.
  stopIfInterrupted("the publication of the outputs");
  // Listed before anything moves: if the process dies in between, the next
  // run still knows every file this one and the last may have left.
  const std::set<std::string> previous = previousOutputs();
  std::set<std::string> pending = previous;
  pending.insert(inside_.begin(), inside_.end());
  writeManifest(pending);
  std::set<std::string> published;
  try {
    for (std::size_t i = 0; i < files_.size(); ++i) {
      files_[i]->publish();
      if (!listed_[i].empty()) published.insert(listed_[i]);
    }
  } catch (const OutputError&) {
    // What is there: the last run's files, untouched, and those published.
    published.insert(previous.begin(), previous.end());
    writeManifest(published);
    throw;
  }
  std::vector<std::string> removed;
  std::set<std::string> listed = inside_;
  const FolderHandle folder(folder_);
  for (const std::string& entry : previous) {
    if (inside_.count(entry) > 0 || folder.fd < 0) continue;
    if (removeInside(folder.fd, entry)) {
      removed.push_back(entry);
    } else if (struct stat info{}; ::lstat((folder_ / entry).c_str(), &info) == 0) {
      listed.insert(entry);  // still there (a file the user may not remove): still listed
    }
  }
  writeManifest(listed);
  return removed;
}

}  // namespace overlap
