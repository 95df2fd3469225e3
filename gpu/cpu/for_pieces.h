// Runs a loop body over pieces of [0, count) on a oneTBB arena's threads,
// or at once on the calling thread when parallel pieces would not pay.
//
// Rules, each with its reason:
// - With one thread, or fewer than two pieces of `grain`, the body runs once
//   over the whole range on the calling thread: handing out a piece costs
//   more than a small loop.
// - The pieces cover [0, count) exactly once, so a body that writes only its
//   own range needs no lock.
#pragma once

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include <cstddef>

namespace overlap::finders {

// Runs body(first, end) over pieces of [0, count) of at least `grain`.
template <typename Body>
void forPieces(tbb::task_arena& arena, std::size_t count, std::size_t grain, const Body& body) {
  if (arena.max_concurrency() <= 1 || count < 2 * grain) {
    body(std::size_t{0}, count);
    return;
  }
  arena.execute([&] {
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, count, grain),
        [&](const tbb::blocked_range<std::size_t>& range) { body(range.begin(), range.end()); });
  });
}

}  // namespace overlap::finders
