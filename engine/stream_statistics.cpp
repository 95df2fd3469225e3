#include "engine/stream_statistics.h"

#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "gpu/cpu_sap_pair_finder.h"

namespace overlap::engine {

StreamStatistics measureStream(const physics::AabbStream& stream, int first_frame) {
  if (first_frame < 1 || first_frame >= stream.stored_frames) {
    throw std::invalid_argument("first frame " + std::to_string(first_frame) +
                                " leaves no frame of " + std::to_string(stream.stored_frames) +
                                " to measure");
  }
  gpu::CpuSapPairFinder finder;
  std::vector<gpu::ObjectBounds> bounds(static_cast<std::size_t>(stream.objects));
  StreamStatistics statistics;
  const double n = stream.objects;
  double pairs = 0;
  for (int frame = 0; frame < stream.stored_frames; ++frame) {
    const auto boxes = stream.frame(frame);
    double moved = 0;
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      gpu::ObjectBounds& entry = bounds[i];
      const bool same = std::memcmp(entry.min, boxes[i].min, sizeof(entry.min)) == 0 &&
                        std::memcmp(entry.max, boxes[i].max, sizeof(entry.max)) == 0;
      moved += same ? 0 : 1;
      std::memcpy(entry.min, boxes[i].min, sizeof(entry.min));
      std::memcpy(entry.max, boxes[i].max, sizeof(entry.max));
      entry.group = entry.mask = 1;
    }
    finder.launch(bounds);
    const gpu::PairDelta delta = finder.finish();
    const double changed = static_cast<double>(delta.added.size() + delta.removed.size());
    pairs += static_cast<double>(delta.added.size()) - static_cast<double>(delta.removed.size());
    if (frame < first_frame) continue;
    ++statistics.frames;
    statistics.pairs_per_box += pairs / n;
    statistics.changed_pairs += pairs > 0 ? changed / pairs : 0;
    statistics.moving_boxes += moved / n;
    statistics.last_pairs_per_box = pairs / n;
    statistics.last_moving_boxes = moved / n;
  }
  statistics.pairs_per_box /= statistics.frames;
  statistics.changed_pairs /= statistics.frames;
  statistics.moving_boxes /= statistics.frames;
  return statistics;
}

}  // namespace overlap::engine
