// The launch shape every GPU finder's kernels share (nvcc and the emulation
// only), and the one layout of the block of results a frame copies back.
//
// Rules, each with its reason:
// - Every kernel but gpusap's one-block packKernel runs kThreadsPerBlock
//   threads a block, whole warps of kLanes; warp collectives name all lanes
//   (kFullWarp), as every lane of a full warp takes part.
// - A grid-stride kernel's grid is blocksFor(): enough blocks for its items,
//   at least one, at most kMaxBlocks (enough to fill any current GPU; larger
//   problems loop).
// - A result block holds a finder's counts, then the first kHeadEntries
//   entries of each of its kLists lists of changes (gpubf: added and removed,
//   filled at once by atomics; gpusap: one head, added's entries then as many
//   of removed's as fit, packed once both are counted).  A frame that changes
//   fewer pairs (the common case) needs no copy but the block's.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "gpu/pair_finder.h"

namespace overlap::finders {

inline constexpr unsigned kThreadsPerBlock = 256;
inline constexpr unsigned kLanes = 32;
inline constexpr unsigned kFullWarp = 0xFFFFFFFFu;
inline constexpr unsigned kWarpsPerBlock = kThreadsPerBlock / kLanes;
inline constexpr std::uint64_t kMaxBlocks = 1u << 16;
// 32 KiB of IndexPairs a head.
inline constexpr std::size_t kHeadEntries = 1u << 12;

// A grid-stride launch over `items`, `per_block` items a block each round.
inline unsigned blocksFor(std::uint64_t items, std::uint64_t per_block = kThreadsPerBlock) {
  return static_cast<unsigned>(
      std::clamp<std::uint64_t>((items + per_block - 1) / per_block, 1, kMaxBlocks));
}

template <class Counts, unsigned kLists>
struct ResultBlock {
  Counts counts;
  IndexPair head[kLists][kHeadEntries];
};

}  // namespace overlap::finders
