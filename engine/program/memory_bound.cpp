#include "engine/program/memory_bound.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>

#include "engine/program/number_options.h"
#include "engine/program/output_checks.h"
#include "physics/broadphase_replay.h"

namespace overlap::engine {
namespace {

constexpr std::uint64_t kMegabyte = 1000 * 1000;
constexpr std::uint64_t kBoxBytes = 32;  // a stored AABB
// The largest --max-memory: a petabyte, far beyond any machine's memory.
constexpr std::int64_t kMostMegabytes = 1'000'000'000;

}  // namespace

namespace {

std::uint64_t physicalMemory() {
  const long pages = ::sysconf(_SC_PHYS_PAGES);
  const long page_bytes = ::sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page_bytes > 0
             ? static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page_bytes)
             : UINT64_MAX;
}

// ulimit -v, UINT64_MAX where there is none.
std::uint64_t addressSpaceLimit() {
  rlimit address_space{};
  return ::getrlimit(RLIMIT_AS, &address_space) == 0 && address_space.rlim_cur != RLIM_INFINITY
             ? static_cast<std::uint64_t>(address_space.rlim_cur)
             : UINT64_MAX;
}

// What the run may allocate: --max-memory, else the machine's memory.
std::uint64_t allocationLimit(std::uint64_t limit_mb) {
  return limit_mb > 0 ? limit_mb * kMegabyte : physicalMemory();
}

// The limit that binds: a --max-memory above ulimit -v cannot lift it.
std::uint64_t limitBytes(std::uint64_t limit_mb) {
  return std::min(allocationLimit(limit_mb), addressSpaceLimit());
}

}  // namespace

std::uint64_t defaultMemoryLimit() {
  return limitBytes(0);
}

void addMaxMemoryOption(CLI::App& command, std::uint64_t& limit_mb) {
  command
      .add_option(
          "--max-memory", limit_mb,
          "MB the run may allocate for its boxes, its broadphase's structures and the pairs "
          "found, "
          "checked before it does (default: the machine's memory, or ulimit -v if lower)")
      ->check(wholeNumberIn(1, kMostMegabytes))
      ->default_str(std::to_string(defaultMemoryLimit() / kMegabyte));
}

std::uint64_t replayBytes(std::string_view algorithm, std::uint64_t objects) {
  return objects * kBoxBytes +
         physics::BroadphaseReplay::memoryCost(algorithm).bytesFor(objects, 0);
}

namespace {

std::string aboveTheLimit(std::uint64_t limit_mb) {
  const bool address_space = addressSpaceLimit() < allocationLimit(limit_mb);
  const char* source = address_space
                           ? (limit_mb > 0 ? " (ulimit -v, below --max-memory)" : " (ulimit -v)")
                       : limit_mb > 0 ? " (--max-memory)"
                                      : " (the machine's; raise it with --max-memory)";
  return ", above the memory limit " + readableBytes(limitBytes(limit_mb)) + source;
}

}  // namespace

void requireMemory(std::uint64_t bytes, std::uint64_t limit_mb, const std::string& what) {
  if (bytes <= limitBytes(limit_mb)) return;
  throw UsageError(what + " needs " + readableBytes(bytes) + aboveTheLimit(limit_mb));
}

namespace {

// The process's address space now (what ulimit -v bounds), 0 if unknown.
std::uint64_t addressSpaceInUse() {
  std::FILE* statm = std::fopen("/proc/self/statm", "r");
  if (statm == nullptr) return 0;
  unsigned long long pages = 0;
  const bool read = std::fscanf(statm, "%llu", &pages) == 1;
  std::fclose(statm);
  const long page_bytes = ::sysconf(_SC_PAGE_SIZE);
  return read && page_bytes > 0 ? pages * static_cast<std::uint64_t>(page_bytes) : 0;
}

}  // namespace

std::uint64_t pairMemoryLimit(std::uint64_t counted, std::uint64_t limit_mb) {
  const auto left = [](std::uint64_t limit, std::uint64_t held) {
    return limit > held ? limit - held : 1;
  };
  std::uint64_t pairs = left(allocationLimit(limit_mb), counted);
  // Against ulimit -v, what the process already maps counts too (its
  // threads' stacks and heaps), so a refusal comes before a failed mapping;
  // against --max-memory only what the run allocates.
  if (const std::uint64_t address_space = addressSpaceLimit(); address_space != UINT64_MAX) {
    pairs = std::min(pairs, left(address_space, std::max(counted, addressSpaceInUse())));
  }
  return pairs;
}

UsageError pairMemoryRefusal(const physics::PairMemoryError& error, std::uint64_t limit_mb,
                             const std::string& what) {
  const std::uint64_t limit = limitBytes(limit_mb);
  const std::uint64_t besides = limit > error.limit ? limit - error.limit : 0;
  const std::string more_than = error.more_than ? "more than " : "";
  return UsageError(what + ": " + more_than + std::to_string(error.pairs) + " pairs need " +
                    more_than + readableBytes(error.bytes) + ", with the " +
                    readableBytes(besides) + " the run holds besides" + aboveTheLimit(limit_mb));
}

}  // namespace overlap::engine
