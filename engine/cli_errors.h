// How the `overlap` subcommands fail.
//
// A UsageError is the user's input being wrong (an option, a value, a file):
// main() prints it as one line and exits with code 2.  Anything else thrown is
// a failure while working and exits with code 1.  Either way nothing
// half-written is left behind: outputs go through physics/atomic_file.h.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

namespace overlap::engine {

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Creates `dir` if needed and proves it writable by writing a probe file;
// throws UsageError naming the option and the path if it is not.
void prepareOutputDirectory(const std::filesystem::path& dir, std::string_view option);

// The same for a file to be written: its folder is prepared, and a path that
// names an existing directory is a UsageError.
void prepareOutputFile(const std::filesystem::path& file, std::string_view option);

}  // namespace overlap::engine
