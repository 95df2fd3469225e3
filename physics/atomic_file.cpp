#include "physics/atomic_file.h"

#include <fstream>
#include <stdexcept>
#include <string>
#include <system_error>

namespace overlap::physics {

void writeFileAtomically(const std::filesystem::path& path, std::string_view contents) {
  std::filesystem::path partial = path;
  partial += ".partial";
  std::error_code error;
  {
    std::ofstream out(partial, std::ios::binary);
    out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
    if (!out.flush()) {
      std::filesystem::remove(partial, error);
      throw std::runtime_error(path.string() + ": write failed");
    }
  }
  std::filesystem::rename(partial, path, error);
  if (error) {
    std::error_code ignored;
    std::filesystem::remove(partial, ignored);
    throw std::runtime_error(path.string() +
                             ": cannot rename the finished file into place: " + error.message());
  }
}

}  // namespace overlap::physics
