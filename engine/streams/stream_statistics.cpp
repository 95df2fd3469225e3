#include "engine/streams/stream_statistics.h"

#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "gpu/cpu/cpu_sweep_and_prune.h"

namespace overlap::engine {

StreamStatistics measureStream(const physics::AabbStream& stream, int first_frame) {
  if (first_frame < 1 || first_frame >= stream.stored_frames) {
    throw std::invalid_argument("first frame " + std::to_string(first_frame) +
                                " leaves no frame of " + std::to_string(stream.stored_frames) +
                                " to measure");
  }
  finders::CpuSweepAndPruneFinder finder;
  std::vector<finders::ObjectBounds> bounds;
  std::vector<std::uint32_t> changed_boxes;
  StreamStatistics statistics;
  const double n = stream.objects;
  double pairs = 0;
  for (int frame = 0; frame < stream.stored_frames; ++frame) {
    const auto boxes = stream.frame(frame);
    toSearchBounds(boxes, bounds);
    finder.launch(bounds);
    const finders::PairDelta delta = finder.finish();
    const double changed = static_cast<double>(delta.added.size() + delta.removed.size());
    pairs += static_cast<double>(delta.added.size()) - static_cast<double>(delta.removed.size());
    if (frame < first_frame) continue;
    changedBoxes(stream.frame(frame - 1), boxes, changed_boxes);
    const auto moved = static_cast<double>(changed_boxes.size());
    ++statistics.frames;
    statistics.pairs_per_box += pairs / n;
    if (pairs > 0) {  // a share of no pairs is no figure
      ++statistics.frames_with_pairs;
      statistics.changed_pairs += changed / pairs;
    }
    statistics.moving_boxes += moved / n;
    statistics.last_pairs_per_box = pairs / n;
    statistics.last_moving_boxes = moved / n;
  }
  statistics.pairs_per_box /= statistics.frames;
  if (statistics.frames_with_pairs > 0) statistics.changed_pairs /= statistics.frames_with_pairs;
  statistics.moving_boxes /= statistics.frames;
  return statistics;
}

void changedBoxes(std::span<const physics::Aabb> before, std::span<const physics::Aabb> now,
                  std::vector<std::uint32_t>& changed) {
  changed.clear();
  for (std::size_t i = 0; i < now.size(); ++i) {
    if (std::memcmp(&before[i], &now[i], sizeof(physics::Aabb)) != 0) {
      changed.push_back(static_cast<std::uint32_t>(i));
    }
  }
}

void toSearchBounds(std::span<const physics::Aabb> boxes,
                    std::vector<finders::ObjectBounds>& bounds) {
  bounds.resize(boxes.size());
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    std::memcpy(bounds[i].min, boxes[i].min, sizeof(bounds[i].min));
    std::memcpy(bounds[i].max, boxes[i].max, sizeof(bounds[i].max));
    bounds[i].group = bounds[i].mask = 1;
  }
}

}  // namespace overlap::engine
