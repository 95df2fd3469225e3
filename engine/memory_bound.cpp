#include "engine/memory_bound.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>

#include "engine/cli_errors.h"
#include "engine/number_options.h"

namespace overlap::engine {
namespace {

constexpr std::uint64_t kMegabyte = 1000 * 1000;
constexpr std::uint64_t kBoxBytes = 32;  // a stored AABB
// cpubf keeps a bit for every pair of slots: n (n - 1) / 2 bits.
constexpr std::uint64_t kPairsPerByte = 8;
// The largest --max-memory: a petabyte, far beyond any machine's memory.
constexpr std::int64_t kMostMegabytes = 1'000'000'000;

}  // namespace

std::uint64_t defaultMemoryLimit() {
  const long pages = ::sysconf(_SC_PHYS_PAGES);
  const long page_bytes = ::sysconf(_SC_PAGE_SIZE);
  std::uint64_t limit = pages > 0 && page_bytes > 0 ? static_cast<std::uint64_t>(pages) *
                                                          static_cast<std::uint64_t>(page_bytes)
                                                    : UINT64_MAX;
  rlimit address_space{};
  if (::getrlimit(RLIMIT_AS, &address_space) == 0 && address_space.rlim_cur != RLIM_INFINITY) {
    limit = std::min<std::uint64_t>(limit, address_space.rlim_cur);
  }
  return limit;
}

void addMaxMemoryOption(CLI::App& command, std::uint64_t& limit_mb) {
  command
      .add_option("--max-memory", limit_mb,
                  "MB the run may allocate for its boxes and cpubf's pair bits, checked before it "
                  "does (default: the machine's memory, or ulimit -v if lower)")
      ->check(wholeNumberIn(1, kMostMegabytes))
      ->default_str(std::to_string(defaultMemoryLimit() / kMegabyte));
}

std::uint64_t replayBytes(std::string_view algorithm, std::uint64_t objects) {
  std::uint64_t bytes = objects * kBoxBytes;
  // gpubf's bits live on the device, or in cpubf where there is none.
  if (algorithm == "cpubf" || algorithm.starts_with("gpubf")) {
    bytes += objects * (objects - 1) / 2 / kPairsPerByte;
  }
  return bytes;
}

void requireMemory(std::uint64_t bytes, std::uint64_t limit_mb, const std::string& what) {
  const std::uint64_t limit = limit_mb > 0 ? limit_mb * kMegabyte : defaultMemoryLimit();
  if (bytes <= limit) return;
  throw UsageError(
      what + " needs " + readableBytes(bytes) + ", above the memory limit " + readableBytes(limit) +
      (limit_mb > 0 ? " (--max-memory)" : " (the machine's; raise it with --max-memory)"));
}

}  // namespace overlap::engine
