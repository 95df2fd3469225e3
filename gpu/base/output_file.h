// Every file the project writes goes through here (docs/CLI.md, "Outputs").
//
//   * Checked before any work: outputFileProblem() / outputFolderProblem()
//     say why a path cannot be written (empty, a folder, an unwritable
//     parent), so a command refuses it before it starts.
//   * A regular file, or a name that does not exist yet, is written to a
//     unique temporary ".<name>.overlap-<pid>-XXXXXX" in the same folder,
//     created exclusively (O_EXCL) and locked (flock) while open, then
//     flushed, synced and renamed over the name: a reader sees the old file
//     or the whole new one, and two writers of one name never share a
//     temporary.  A symlink is followed: its target is replaced, the link
//     stays a link.
//   * The first output opened in a folder removes the temporaries of that
//     pattern that dead writers left there (a run killed by SIGKILL): the
//     PID is no process's and no one holds the lock.  A live writer's
//     temporary and every other name are left alone.
//   * Anything else that exists (a device, a FIFO, a socket) is written
//     through, never replaced by a regular file.  A FIFO without a reader is
//     waited for through interrupt.h's waitUntil() (said after a second,
//     stopped by a signal); a write blocked on a slow reader is stopped by a
//     signal too (Interrupted).
//   * A write that fails (disk full, I/O error, EPIPE from a reader that
//     has gone: interrupt.h ignores SIGPIPE) throws OutputError naming
//     the output; an output destroyed before it is published leaves nothing
//     but what was there before (its temporary is removed).
//   * OutputFolder keeps a folder of one run's outputs whole: everything is
//     published together at commit(), and the files the previous run listed
//     in the folder's manifest and this run does not write are removed.
//     Files the program did not write are never removed.
// Plain POSIX and the standard library: no Bullet here.
#pragma once

#include <filesystem>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace overlap {

// A failure while writing an output: the program's (exit 1), not the user's.
struct OutputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Empty when `file` can be written, else why not (for a message that names
// the option and the path first): an empty name, a name ending in '/', an
// existing folder, a parent that is not a folder or cannot be created or
// written.  Creates missing parent folders.
std::string outputFileProblem(const std::filesystem::path& file);
// The same for a folder that will hold outputs (created if missing).
std::string outputFolderProblem(const std::filesystem::path& folder);

class OutputFile {
 public:
  // Opens the output (see above); throws OutputError naming it if it cannot.
  explicit OutputFile(std::filesystem::path path);
  ~OutputFile();  // not published: the temporary is removed
  OutputFile(OutputFile&& other) noexcept;
  OutputFile& operator=(OutputFile&& other) = delete;
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  void write(std::string_view bytes);
  // Rewrites bytes already written at `offset` (a WAV header's sizes).
  // Only for an output that is not written through.
  void rewrite(std::uint64_t offset, std::string_view bytes);
  // Flushes and syncs the whole file and closes it, still under its
  // temporary name (nothing more for an output written through).
  void finish();
  // Renames the finished temporary over the name; refuses if the name has
  // meanwhile become something other than a regular file.
  void publish();
  void commit() {
    finish();
    publish();
  }

  const std::filesystem::path& path() const { return path_; }
  // True for a device, FIFO or socket: written in place, nothing to rename.
  bool writtenThrough() const { return temporary_.empty(); }

 private:
  [[noreturn]] void fail(const std::string& what) const;

  std::filesystem::path path_;       // as given: what messages name
  std::filesystem::path target_;     // path_ with symlinks followed
  std::filesystem::path temporary_;  // empty when written through
  int fd_ = -1;
  bool finished_ = false;
  bool published_ = false;
};

// Writes `contents` as the whole of `path` through an OutputFile.
void writeFileAtomically(const std::filesystem::path& path, std::string_view contents);

// Writes to standard output; throws OutputError ("stdout: ...") on failure.
void writeStandardOutput(std::string_view bytes);

// One run's outputs in one folder, published together (see above).  The
// manifest ".overlap-outputs" lists, one per line, the paths relative to the
// folder that the last committed run wrote there.
class OutputFolder {
 public:
  static constexpr const char* kManifestName = ".overlap-outputs";

  // The folder must exist (outputFolderProblem() creates it).
  explicit OutputFolder(std::filesystem::path folder);

  const std::filesystem::path& folder() const { return folder_; }
  // Opens an output published at commit(): inside the folder (its own
  // folder must exist) it joins the manifest; outside it (a --wav elsewhere)
  // it is only published with the rest.
  OutputFile& open(const std::filesystem::path& path);
  // Finishes every output, publishes them all, removes the previous run's
  // outputs this run did not write, and writes the new manifest.
  void commit();

 private:
  std::set<std::string> previousOutputs() const;
  void writeManifest(const std::set<std::string>& entries) const;

  std::filesystem::path folder_;
  std::vector<std::unique_ptr<OutputFile>> files_;
  std::set<std::string> inside_;  // the outputs inside the folder, relative to it
};

}  // namespace overlap
