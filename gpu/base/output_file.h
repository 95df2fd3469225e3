// Every file the project writes goes through here (docs/CLI.md, "Outputs").
//
//   * Checked before any work, creating nothing: outputFileProblem() /
//     outputFolderProblem() say why a path cannot be written (empty, a
//     folder, '.', a symlink loop, a name too long, an unwritable parent),
//     so a command refuses it before it starts and leaves no folder behind.
//     Missing folders are made when the first output is opened.
//   * A regular file, or a name that does not exist yet, is written to a
//     unique temporary ".<name>.overlap-<pid>-XXXXXX" in the same folder
//     (<name> cut short where the whole would exceed the longest name),
//     created exclusively (O_EXCL) and locked (flock) while open, then
//     flushed, synced and renamed over the name: a reader sees the old file
//     or the whole new one, and two writers of one name never share a
//     temporary.  A symlink named by the user is followed: its target is
//     replaced, the link stays a link.  Inside a run folder (OutputFolder)
//     no link is followed: a link in an output's own name is replaced by the
//     file, and a linked folder between the run folder and an output is
//     refused (declare, and again at open).
//   * An open descriptor named through its links (/dev/stdout, /dev/fd/N,
//     /proc/self/fd/N) is written to itself (descriptorOfOutput), whatever
//     it is: `--out /dev/stdout >> log` appends, an unlinked file or a
//     memfd gets the bytes.  A device or FIFO is reached through the name
//     as given; a socket, which no program can open, is refused.
//   * The first output opened in a folder removes the temporaries of that
//     pattern that dead writers left there (a run killed by SIGKILL): the
//     PID is no process's and no one holds the lock.  A live writer's
//     temporary and every other name are left alone.
//   * Anything else that exists (a device, a FIFO) is written through,
//     never replaced by a regular file.  A replaced regular file keeps its
//     owner (where the process may give it) and permissions, never a
//     set-ID bit.  A FIFO without a reader is
//     waited for through interrupt.h's waitUntil() (said after a second,
//     stopped by a signal); a write to anything but a regular file looks
//     for a signal every tenth of a second while it waits (Interrupted), as
//     a reader that does not read would block it and the signal may reach
//     another thread: a pipe, FIFO or socket is polled for room, a device
//     (a terminal) is woken by a timer signal aimed at the writing thread.
//     A descriptor is written through itself, never reopened (/dev/tty
//     reopens as the opener's terminal).  An output written through that is
//     standard error, however named, is refused, and so are /dev/ptmx
//     (each open makes a new terminal) and a device that cannot be opened
//     (/dev/tty without a terminal), before any work.
//   * A write that fails (disk full, I/O error, EPIPE from a reader that
//     has gone: interrupt.h ignores SIGPIPE) throws OutputError naming
//     the output; an output destroyed before it is published leaves nothing
//     but what was there before (its temporary, and the folders made for
//     it, are removed).
//   * OutputFolder keeps a folder of one run's outputs whole: everything is
//     published together at commit(), and the files the previous run listed
//     in the folder's manifest and this run does not write are removed.
//     Files the program did not write are never removed: the manifest
//     escapes every name (a newline cannot split one into two), one
//     without this format's first line lists nothing, the manifest is never
//     read through a link (declare() refuses one that is a FIFO or a
//     folder, which would hang or fail the commit), and an entry is
//     removed only if it is a regular file reached from the folder without
//     following any link (openat, O_NOFOLLOW); one that cannot be removed
//     stays listed.  declare() refuses, before any work, a listed file this
//     user could not replace or remove (another's in a sticky folder) and a
//     folder between this one and an output that holds a list of its own.
//     A list larger than any a run writes (64 MiB) lists nothing, and the
//     folders above are searched only for lists this user wrote.
//   * Two outputs of one run never share a path: declare() refuses, before
//     any work and however the names are spelled, a second name for a file
//     already declared, a file that is the run folder, a folder above it or
//     a folder of another output, and a file inside another output.  Names
//     are compared by where the kernel puts them, never by their text: the
//     folder holding each is opened one part at a time (a link followed
//     from where it stands, so "link/.." is the parent of the link's
//     target), and its path as the kernel has it, plus the name, is the
//     file's identity; folders not made yet keep their names.
//   * commit() lists in the manifest only files that are there: if a rename
//     fails, the list is rewritten with what was published and what the
//     last run left, before the error goes on.
//   * A signal (interrupt.h) that arrived before commit() starts moving
//     anything stops it: nothing is published (Interrupted is thrown).
// Plain POSIX and the standard library: no Bullet here.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
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

// The open descriptor of this process that an output `path` reaches through
// its links (/dev/stdout, /dev/fd/N, /proc/self/fd/N, a link to one), which
// the output is written to itself, sharing its offset and append mode (the
// file behind it may be unlinked or a memfd, which no name reaches); -1
// for none.  The checks refuse another process's descriptor.
int descriptorOfOutput(const std::filesystem::path& path);

// The file an output `path` names with its links followed (at most 40, as
// the kernel does; a dangling link gives the name it points to, where the
// file will be made): where a temporary goes and whose folder's room counts.
std::filesystem::path outputTarget(const std::filesystem::path& path);

// The nearest folder of `path` that exists, `path` itself included ("." for
// a relative path with none): where a file of a folder not made yet will go.
std::filesystem::path nearestExisting(std::filesystem::path path);
// Empty when `file` can name a file to write, else why not: an empty name,
// or one that names a folder ("dir/", "dir/.", "..").
std::string outputNameProblem(const std::filesystem::path& file);
// Empty when `file` can be written, else why not (for a message that names
// the option and the path first): outputNameProblem(), an existing folder,
// a path that cannot be reached (a symlink loop), a name longer than its
// folder takes, a parent that is not a folder or cannot be created or
// written.  Creates nothing.
std::string outputFileProblem(const std::filesystem::path& file);
// outputFileProblem() that tries each folder once: those in
// `writable_folders` passed before, and those that pass are added.
std::string outputFileProblemIn(const std::filesystem::path& file,
                                std::set<std::filesystem::path>* writable_folders);
// The same for a folder that will hold outputs (created when opened).
std::string outputFolderProblem(const std::filesystem::path& folder);

// A manifest line: `name` with '\', newline and carriage return escaped as
// \\, \n and \r, so every line is one name.  The reverse gives nothing
// for a line no name escapes to.
std::string escapeManifestEntry(std::string_view name);
std::optional<std::string> unescapeManifestEntry(std::string_view line);

// How an output's own name is taken when it is a symlink: a name given by
// the user is followed (the target is replaced); a name inside a run folder
// is not (the link itself is replaced by the file, its target untouched).
enum class FinalLink { kFollow, kReplace };

class OutputFile {
 public:
  // Opens the output (see above); throws OutputError naming it if it cannot.
  explicit OutputFile(std::filesystem::path path, FinalLink link = FinalLink::kFollow);
  ~OutputFile();  // not published: the temporary is removed
  OutputFile(OutputFile&& other) noexcept;
  OutputFile& operator=(OutputFile&& other) = delete;
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  void write(std::string_view bytes);
  // Rewrites bytes already written at `offset` from the output's start (a
  // WAV header's sizes).  Only for a rewritable() output.
  void rewrite(std::uint64_t offset, std::string_view bytes);
  // True for a temporary, and for a descriptor that is a regular file not
  // appended to, now (its start is where this output began); false once
  // finished.
  bool rewritable() const;
  // Flushes and syncs the whole file and closes it, still under its
  // temporary name (nothing more for an output written through).
  void finish();
  // Renames the finished temporary over the name; refuses if the name has
  // meanwhile become something other than a regular file.  Looks at no
  // signal: the caller decides when the last chance to stop is.
  void publish();
  // finish(), then publish() unless a signal arrived (interrupt.h):
  // Interrupted is thrown and nothing is published.
  void commit();

  const std::filesystem::path& path() const { return path_; }
  // True for what is written in place (an open descriptor, a device, a
  // FIFO): nothing to rename.
  bool writtenThrough() const { return temporary_.empty(); }

 private:
  [[noreturn]] void fail(const std::string& what) const;

  std::filesystem::path path_;       // as given: what messages name
  std::filesystem::path target_;     // path_ with symlinks followed (kFollow)
  bool replace_link_ = false;        // kReplace: a symlink at path_ is replaced
  std::filesystem::path temporary_;  // empty when written through
  int fd_ = -1;
  bool finished_ = false;
  bool published_ = false;
  bool noted_written_through_ = false;  // noteWrittenThrough() told of its first bytes
  std::int64_t rewrite_base_ = 0;       // where the output starts in its file; -1: not rewritable
  std::vector<std::filesystem::path> created_folders_;  // made for it, removed unless published
};

// Writes `contents` as the whole of `path` through an OutputFile.
void writeFileAtomically(const std::filesystem::path& path, std::string_view contents);

// Writes to standard output; throws OutputError ("stdout: ...") on failure.
void writeStandardOutput(std::string_view bytes);

// One run's outputs in one folder, published together (see above).  The
// manifest ".overlap-outputs" starts with kManifestHeader, then lists, one
// escaped name per line, the paths relative to the folder that the last
// committed run wrote there.
class OutputFolder {
 public:
  static constexpr const char* kManifestName = ".overlap-outputs";
  static constexpr const char* kManifestHeader =
      "# overlap outputs v2: the files the last `overlap` run wrote in this folder, one a line "
      "(\\ and newline escaped as \\\\ and \\n), removed by the next run that does not write "
      "them";

  // Creates nothing: a missing folder is made when the first output opens.
  // `writer` names the subcommand whose outputs the folder keeps; the
  // manifest records it (a second line, "\\writer NAME", which an older
  // reader skips as no name), and declare() refuses a folder whose manifest
  // names another: each would remove the other's outputs.
  explicit OutputFolder(std::filesystem::path folder, std::string writer = "run");
  // A list written before the writer line is taken only when `mine` says
  // every entry is one this subcommand writes (a capture's keyframes, a
  // run's files); declare() refuses it otherwise.  Unset: any such list.
  void takeOlderListsWhen(std::function<bool(const std::string& entry)> mine) {
    older_list_is_mine_ = std::move(mine);
  }
  ~OutputFolder();  // what was never published leaves nothing, folders made for it included
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

  const std::filesystem::path& folder() const { return folder_; }
  // Before any work, each output the run will write: empty when `path` can
  // be written (outputFileProblem) and is no other declared output's file,
  // else why not.
  std::string declare(const std::filesystem::path& path);
  // Opens an output published at commit(): inside the folder (its own
  // folder must exist) it joins the manifest; outside it (a --wav elsewhere)
  // it is only published with the rest.  Opening one file twice throws.
  OutputFile& open(const std::filesystem::path& path);
  // Finishes every output, publishes them all, removes the previous run's
  // outputs this run did not write, and writes the new manifest.  Returns
  // the names it removed, relative to the folder.
  std::vector<std::string> commit();

 private:
  std::string identity(const std::filesystem::path& path) const;
  // `path` relative to the folder when the file it names is inside it, as
  // the kernel resolves the folders on the way (links and ".." alike).
  std::optional<std::filesystem::path> inside(const std::filesystem::path& path) const;
  // Empty unless `path`, as named, passes a symlink after it has reached
  // the run folder.
  std::string linkProblem(const std::filesystem::path& path) const;
  std::set<std::string> previousOutputs() const;
  // The manifest's text, read without following a link ("" for none).
  std::string manifestText() const;
  // Why the folder is no folder of its own, or "": a folder above it whose
  // list names files in it (a run's frames/), which this run would replace.
  std::string enclosingRunProblem() const;
  // Why an output at `relative` is not this folder's own, or "": a folder
  // between the two holds a list of its own (a capture's in a run's frames/).
  std::string innerListProblem(const std::filesystem::path& relative) const;
  // Why the last run's listed outputs `previous` cannot all be replaced or
  // removed, or "": another user's file in a sticky folder, a file in a
  // folder that now holds another list.
  std::string previousOutputsProblem(const std::set<std::string>& previous) const;
  void writeManifest(const std::set<std::string>& entries) const;

  std::filesystem::path folder_;
  std::string writer_;
  bool writer_checked_ = false;  // declare() compared the manifest's writer once
  std::function<bool(const std::string&)> older_list_is_mine_;
  std::string folder_identity_;
  std::vector<std::unique_ptr<OutputFile>> files_;
  std::vector<std::string> listed_;  // files_[i]'s manifest entry; empty: outside the folder
  std::set<std::string> inside_;     // the outputs inside the folder, relative to it
  std::map<std::string, std::string> declared_;       // identity() -> the name declared
  std::set<std::filesystem::path> writable_folders_;  // tried once by declare()
  std::set<std::string> opened_;                      // identity() of each file opened
};

}  // namespace overlap
