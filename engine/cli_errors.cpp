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

}  // namespace overlap::engine
