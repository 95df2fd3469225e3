#include "engine/program/output_checks.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cstdio>
#include <iterator>
#include <utility>

#include "gpu/base/output_file.h"

namespace overlap::engine {
namespace {

std::string shownPath(const std::filesystem::path& path) {
  return path.empty() ? std::string("\"\"") : path.string();
}

}  // namespace

void prepareOutputDirectory(const std::filesystem::path& dir, std::string_view option) {
  if (const std::string problem = outputFolderProblem(dir); !problem.empty()) {
    throw UsageError(std::string(option) + " " + shownPath(dir) + ": " + problem);
  }
}

void prepareOutputFile(const std::filesystem::path& file, std::string_view option) {
  if (const std::string problem = outputFileProblem(file); !problem.empty()) {
    throw UsageError(std::string(option) + " " + shownPath(file) + ": " + problem);
  }
}

void requireFreeSpace(const std::filesystem::path& file, std::uint64_t bytes,
                      std::string_view option) {
  std::error_code error;
  std::uint64_t available = 0;
  if (const int descriptor = descriptorOfOutput(file); descriptor >= 0) {
    // Written to the descriptor: the room of the file system it is on.
    struct stat info {};
    struct statvfs room {};
    if (::fstat(descriptor, &info) != 0 || !S_ISREG(info.st_mode)) return;
    // A file system that counts no blocks (a memfd's, /proc) has no room to check.
    if (::fstatvfs(descriptor, &room) != 0 || room.f_blocks == 0) return;
    available = static_cast<std::uint64_t>(room.f_bavail) * room.f_frsize;
  } else {
    const std::filesystem::file_status status = std::filesystem::status(file, error);
    if (std::filesystem::exists(status) && !std::filesystem::is_regular_file(status)) return;
    // The folder it goes to, links followed (a link to a file not made yet
    // included), or the nearest one that exists (made by the run).
    const std::filesystem::path target = outputTarget(std::filesystem::absolute(file, error));
    const std::filesystem::path folder =
        nearestExisting(std::filesystem::weakly_canonical(target, error).parent_path());
    const std::filesystem::space_info space = std::filesystem::space(folder, error);
    if (error) return;  // unknown here: a full disk is then reported by the write
    available = space.available;
  }
  if (bytes > available) {
    throw UsageError(std::string(option) + " " + shownPath(file) + ": needs " +
                     readableBytes(bytes) + ", and its folder has " + readableBytes(available) +
                     " free");
  }
}

std::string readableBytes(std::uint64_t bytes) {
  static constexpr const char* kUnits[] = {"bytes", "kB", "MB", "GB", "TB", "PB", "EB"};
  auto value = static_cast<double>(bytes);
  std::size_t unit = 0;
  while (value >= 1000 && unit + 1 < std::size(kUnits)) {
    value /= 1000;
    ++unit;
  }
  char text[32];
  std::snprintf(text, sizeof(text), unit == 0 ? "%.0f %s" : "%.1f %s", value, kUnits[unit]);
  return text;
}

namespace {

// Where the kernel puts `path` once the folders missing on its way are made:
// each existing part resolved (links followed from where they stand), a
// missing one kept as written (it will be a folder), `..` the parent of what
// was reached.  So `sub/../link/x`, sub missing, is `link`'s target's x.
std::filesystem::path reachedPath(const std::filesystem::path& path) {
  std::error_code error;
  std::filesystem::path reached = std::filesystem::absolute(path, error).root_path();
  for (const std::filesystem::path& part : std::filesystem::absolute(path, error).relative_path()) {
    if (part == ".") continue;
    if (part == "..") {
      reached = reached.parent_path();
      continue;
    }
    reached /= part;
    if (std::filesystem::exists(std::filesystem::symlink_status(reached, error))) {
      std::filesystem::path resolved = std::filesystem::canonical(reached, error);
      if (!error) reached = std::move(resolved);
    }
  }
  return reached;
}

}  // namespace

void refuseOutputsOverInputs(const std::vector<std::filesystem::path>& outputs,
                             std::string_view output_option,
                             const std::vector<std::filesystem::path>& inputs,
                             std::string_view input_option) {
  for (const std::filesystem::path& output : outputs) {
    for (const std::filesystem::path& input : inputs) {
      std::error_code error;
      const bool same = (std::filesystem::equivalent(output, input, error) && !error) ||
                        reachedPath(output) == reachedPath(input);
      if (same) {
        throw UsageError(std::string(output_option) + " " + shownPath(output) + ": it is " +
                         std::string(input_option) + " " + shownPath(input) +
                         ", which the results would replace; write them elsewhere");
      }
    }
  }
}

void refuseStandardOutputOverInput(const std::filesystem::path& input,
                                   std::string_view input_option) {
  struct stat in {};
  if (::stat(input.c_str(), &in) != 0) return;  // the input's own check names it
  // A file, or a FIFO (`1<>FIFO`: the program's own write end would keep the
  // FIFO from ever ending); stderr too, which gets the summary.
  if (!S_ISREG(in.st_mode) && !S_ISFIFO(in.st_mode)) return;
  const auto isInput = [&](int fd) {
    struct stat out {};
    return ::fstat(fd, &out) == 0 && out.st_dev == in.st_dev && out.st_ino == in.st_ino;
  };
  const bool over_stdout = isInput(STDOUT_FILENO);
  const bool over_stderr = isInput(STDERR_FILENO);
  if (!over_stdout && !over_stderr) return;
  // With standard error the input, the message itself would be written over
  // it (`>>FILE 2>&1` too): into /dev/null with it, the exit status says no.
  if (over_stderr) {
    const int null = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
    if (null >= 0) {
      ::dup2(null, STDERR_FILENO);
      ::close(null);
    }
  }
  throw UsageError(std::string(over_stdout ? "standard output" : "standard error") + " is " +
                   std::string(input_option) + " " + shownPath(input) +
                   ", which what is written there would overwrite; send it elsewhere");
}

std::vector<std::filesystem::path> prepareOutputFiles(const std::filesystem::path& prefix,
                                                      const std::vector<std::string>& suffixes,
                                                      std::string_view option) {
  if (const std::string problem = outputNameProblem(prefix); !problem.empty()) {
    throw UsageError(std::string(option) + " " + shownPath(prefix) + ": " + problem);
  }
  // The prefix itself is never written: its files go beside it, so a
  // folder, device, FIFO or socket there (/dev/null, /dev/shm) is a name
  // mistaken for a file.
  std::error_code error;
  const std::filesystem::file_status status = std::filesystem::status(prefix, error);
  if (std::filesystem::is_directory(status)) {
    throw UsageError(std::string(option) + " " + shownPath(prefix) +
                     ": is a folder, not a prefix of files (they would be made beside it); name "
                     "them inside it, as " +
                     (prefix / "results").string());
  }
  // An open descriptor's name (/dev/stdout, /proc/self/fd/N) is the same
  // mistake whatever the descriptor is: its files would be made in /dev or
  // /proc.
  if ((std::filesystem::exists(status) && !std::filesystem::is_regular_file(status)) ||
      descriptorOfOutput(prefix) >= 0) {
    throw UsageError(std::string(option) + " " + shownPath(prefix) +
                     ": is a device, FIFO, socket or open descriptor, not a prefix of files "
                     "(its files would be made beside it)");
  }
  std::vector<std::filesystem::path> files;
  for (const std::string& suffix : suffixes) {
    files.push_back(prefix);
    files.back() += suffix;
    prepareOutputFile(files.back(), option);
  }
  return files;
}

void declareOutput(OutputFolder& outputs, const std::filesystem::path& file,
                   std::string_view option) {
  if (const std::string problem = outputs.declare(file); !problem.empty()) {
    throw UsageError(std::string(option) + " " + shownPath(file) + ": " + problem);
  }
}

}  // namespace overlap::engine
