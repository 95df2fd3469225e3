// Scratch paths for the tests, in the system's temp folder, and a file's
// bytes read back whole.  Each path
// carries the test process's id: ctest runs tests in parallel processes, and
// two checkouts of the project may run their suites on one machine at once,
// so a fixed name would let one run delete or read another's files.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace overlap::testing {

// temp/overlap_<pid>_<name>; `name` may end in an extension.
inline std::filesystem::path scratchPath(const std::string& name) {
  return std::filesystem::temp_directory_path() /
         ("overlap_" + std::to_string(::getpid()) + "_" + name);
}

// The file's bytes; none where it cannot be read.
inline std::vector<char> fileBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

}  // namespace overlap::testing
