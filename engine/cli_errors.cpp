#include "engine/cli_errors.h"

#include <fstream>
#include <system_error>

namespace overlap::engine {

void prepareOutputDirectory(const std::filesystem::path& dir, std::string_view option) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) {
    throw UsageError(std::string(option) + " " + dir.string() +
                     ": cannot create: " + error.message());
  }
  const std::filesystem::path probe = dir / ".overlap-write-probe";
  {
    std::ofstream out(probe);
    if (!out || !(out << "probe") || !out.flush()) {
      throw UsageError(std::string(option) + " " + dir.string() + ": not writable");
    }
  }
  std::filesystem::remove(probe, error);
}

void prepareOutputFile(const std::filesystem::path& file, std::string_view option) {
  std::error_code error;
  if (std::filesystem::is_directory(file, error)) {
    throw UsageError(std::string(option) + " " + file.string() + ": is a directory, not a file");
  }
  prepareOutputDirectory(file.has_parent_path() ? file.parent_path() : ".", option);
}

}  // namespace overlap::engine
