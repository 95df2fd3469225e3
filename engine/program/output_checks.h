// The checks of a program's outputs before any work (docs/CLI.md,
// "Outputs"): a folder or file that cannot be written, two outputs that are
// one file, a disk without room for a stream, each a UsageError naming the
// option and the path.  None creates anything: outputs are written through
// gpu/base/output_file.h, which publishes them whole or not at all.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "engine/program/usage_error.h"
#include "gpu/base/output_file.h"

namespace overlap::engine {

// Checks that `dir` can hold outputs (outputFolderProblem; it is created
// when the first output opens); throws UsageError naming the option and the
// path if it cannot.  Creates nothing.
void prepareOutputDirectory(const std::filesystem::path& dir, std::string_view option);

// The same for a file to be written (outputFileProblem): an empty
// name, a folder, an unwritable folder are UsageErrors.
void prepareOutputFile(const std::filesystem::path& file, std::string_view option);

// Throws UsageError naming the option when `file`'s folder has less free
// space than `bytes` (a regular file or a new name; nothing for a device or
// FIFO, which stores nothing).  The old file stays until the new one is
// whole, so the new one needs all of `bytes`.
void requireFreeSpace(const std::filesystem::path& file, std::uint64_t bytes,
                      std::string_view option);

// "3.2 GB": a size a user reads at a glance (decimal units).
std::string readableBytes(std::uint64_t bytes);

// The files `prefix` + each suffix ("--out results" -> results.csv,
// results.json), each checked as above; the prefix itself must name a file
// ("", ".", "dir/" and "/" are UsageErrors), and not a folder, device, FIFO or
// socket (/dev/null: the files would be made beside it).
std::vector<std::filesystem::path> prepareOutputFiles(const std::filesystem::path& prefix,
                                                      const std::vector<std::string>& suffixes,
                                                      std::string_view option);

// A UsageError when one of `outputs` is one of `inputs` (the same file, as
// the kernel resolves both: links and '..' followed), so that a run never
// replaces what it reads: "--out z: z.csv is --input r/z.csv".
void refuseOutputsOverInputs(const std::vector<std::filesystem::path>& outputs,
                             std::string_view output_option,
                             const std::vector<std::filesystem::path>& inputs,
                             std::string_view input_option);

// A UsageError when standard output or standard error is the file or FIFO
// `input` (`1<>FILE`, `>>FILE`, `2<>FILE`): what is written there would
// overwrite what is being read, or keep a FIFO from ever ending.
void refuseStandardOutputOverInput(const std::filesystem::path& input,
                                   std::string_view input_option);

// The same for one output of a run's folder (OutputFolder::declare): also a
// UsageError when another output of the run is that file.
void declareOutput(OutputFolder& outputs, const std::filesystem::path& file,
                   std::string_view option);

}  // namespace overlap::engine
