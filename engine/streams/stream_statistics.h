// What a stream asks of a broadphase, to compare generated streams
// (engine/streams/stream_generator.h) with recorded ones: per frame, the exact pairs
// per box, the share of them that changed since the frame before (added plus
// removed over this frame's pairs; none for a frame without pairs), and the
// share of boxes whose AABB moved.
// The pairs are cpusap's (exact; gpu/cpu/cpu_sweep_and_prune.h), every box in one
// filter group.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "gpu/pair_finder.h"
#include "physics/aabb_stream.h"

namespace overlap::engine {

struct StreamStatistics {
  int frames = 0;             // frames measured: first_frame .. the last
  double pairs_per_box = 0;   // mean over those frames
  int frames_with_pairs = 0;  // of those, the frames that have any pair
  double changed_pairs = 0;   // mean share of pairs added or removed, over frames_with_pairs
  double moving_boxes = 0;    // mean share of boxes whose AABB changed
  double last_pairs_per_box = 0;
  double last_moving_boxes = 0;
};

// Over frames [first_frame, stored_frames), first_frame >= 1 (each compares
// with the frame before).  Throws std::invalid_argument when there is none.
StreamStatistics measureStream(const physics::AabbStream& stream, int first_frame);

// The indices of the boxes of `now` whose bytes differ from `before`'s (the
// same frame's boxes, one frame apart).
void changedBoxes(std::span<const physics::Aabb> before, std::span<const physics::Aabb> now,
                  std::vector<std::uint32_t>& changed);

// A stream's frame as the pair finders take it: every box in one filter
// group, so every overlapping pair counts.
void toSearchBounds(std::span<const physics::Aabb> boxes,
                    std::vector<finders::ObjectBounds>& bounds);

}  // namespace overlap::engine
