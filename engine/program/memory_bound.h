// Memory bounds (docs/CLI.md, "Memory"): the largest allocations a command
// would make, computed from its input's counts and checked before anything
// is allocated, against one limit.
//
// Rules:
//   * The limit is --max-memory (MB), by default the machine's physical
//     memory; the process's address-space limit (ulimit -v) where lower,
//     whatever --max-memory says (it cannot lift a ulimit): a
//     run that cannot fit fails in a second with exit 2 naming what needs the
//     memory, not after minutes with std::bad_alloc or the OOM killer.
//   * What is counted first is what a count in the input decides alone: a
//     frame of N boxes (N x 32 bytes, a header's N on a pipe included) and
//     what the broadphase holds for N boxes before its first pair, by the
//     rates each one states (finders::MemoryCost, BroadphaseInfo::memory;
//     cpubf's and gpubf's bit matrices of every pair of slots among them).
//   * What grows with the pairs found is bounded by what is left: the pair
//     cache (physics/broadphase/bulk_pair_cache.h, with our finders' own pair lists)
//     refuses to grow past it, and our finders stop collecting a frame's
//     pairs past the most it could hold (finders::PairFinder::setPairLimit);
//     the command exits 2 with the pair count and the memory they need.
//   * Whatever allocation still fails throws std::bad_alloc (Bullet's
//     included), which the commands report as running out of memory, exit 1.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>
#include <string_view>

#include "engine/program/usage_error.h"
#include "physics/broadphase/bulk_pair_cache.h"

namespace overlap::engine {

// The default limit, in bytes.
std::uint64_t defaultMemoryLimit();

// Registers --max-memory (MB) into `limit_mb`, 0 meaning the default.
void addMaxMemoryOption(CLI::App& command, std::uint64_t& limit_mb);

// Bytes a replay of `objects` boxes with `algorithm` allocates before its
// first pair: one frame of boxes and BroadphaseReplay::memoryCost()'s
// bytes for that many slots (a device finder without a device: its
// fallback's).
std::uint64_t replayBytes(std::string_view algorithm, std::uint64_t objects);

// Throws UsageError "WHAT needs X, above the memory limit Y (--max-memory)"
// when `bytes` is above the limit (`limit_mb` as registered).
void requireMemory(std::uint64_t bytes, std::uint64_t limit_mb, const std::string& what);

// What the limit leaves for pairs once `counted` bytes are held (at least
// one byte: a limit stays a limit).
std::uint64_t pairMemoryLimit(std::uint64_t counted, std::uint64_t limit_mb);

// The UsageError for pairs the limit cannot hold: "WHAT: N pairs need X,
// with the Y the run holds besides above the memory limit Z (--max-memory)";
// "more than N pairs need more than X" where a finder stopped at the limit.
UsageError pairMemoryRefusal(const physics::PairMemoryError& error, std::uint64_t limit_mb,
                             const std::string& what);

}  // namespace overlap::engine
