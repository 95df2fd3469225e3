// A plain driver for a fuzz target, for the builds without libFuzzer (the
// ASan + UBSan build, gcc): each file named, and each file inside each folder
// named, goes through LLVMFuzzerTestOneInput once, in name order.  A crash,
// a sanitizer report or a broken promise (the targets abort) fails the run,
// as in libFuzzer's own replay (`-runs=0`); so does a folder or file that is
// missing or holds no input, so a lost corpus cannot pass unseen.
// Usage: replay_<input> PATH...
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <system_error>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

namespace fs = std::filesystem;

// The files under `path` (or `path` itself), in name order; empty if none.
std::vector<fs::path> inputsAt(const fs::path& path) {
  std::error_code error;
  if (!fs::is_directory(path, error)) {
    if (fs::is_regular_file(path, error)) return {path};
    return {};
  }
  std::vector<fs::path> files;
  for (const fs::directory_entry& entry : fs::directory_iterator(path, error)) {
    if (entry.is_regular_file(error)) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s PATH...  (files, or folders of files, to replay)\n", argv[0]);
    return 2;
  }
  int replayed = 0;
  for (int i = 1; i < argc; ++i) {
    const std::vector<fs::path> inputs = inputsAt(argv[i]);
    if (inputs.empty()) {
      std::fprintf(stderr, "%s: %s: no such file, or a folder without files\n", argv[0], argv[i]);
      return 2;
    }
    for (const fs::path& input : inputs) {
      std::ifstream file(input, std::ios::binary);
      if (!file) {
        std::fprintf(stderr, "%s: %s: cannot open\n", argv[0], input.c_str());
        return 2;
      }
      const std::vector<char> bytes{std::istreambuf_iterator<char>(file),
                                    std::istreambuf_iterator<char>()};
      std::fprintf(stderr, "replaying %s (%zu bytes)\n", input.c_str(), bytes.size());
      LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
      ++replayed;
    }
  }
  std::fprintf(stderr, "%s: %d inputs replayed, none failed\n", argv[0], replayed);
  return 0;
}
