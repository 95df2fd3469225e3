// What one steady frame of a pair finder asks of the CUDA emulation's device
// (gpu/emulation/api_counters.h): API calls, launches, copies and the bytes
// they carry.  A steady frame follows warm-up frames at the same n, so no
// buffer grows in it.  Emulation build only.
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

#include "gpu/emulation/api_counters.h"
#include "gpu/pair_finder.h"

namespace overlap::finders::testing {

// n boxes on a line, 0.9 apart and 1 wide, every other one shifted by 0.2:
// each overlaps one neighbour, and the neighbour changes with the frame's
// parity, so every pair changes each frame.
inline std::vector<ObjectBounds> steppingBoxes(std::uint32_t n, int frame) {
  std::vector<ObjectBounds> boxes(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    const float x = 0.9f * static_cast<float>(i) + ((i + frame) % 2 == 0 ? 0.0f : 0.2f);
    boxes[i] = ObjectBounds{{x, 0, 0}, {x + 1, 1, 1}, 1, -1};
  }
  return boxes;
}

// The counts of frame `warm_up` after `warm_up` frames; the boxes go through
// the finder's staging where it has one, as a caller that fills it would.
inline cuda_emulation::ApiCounters steadyFrameCost(PairFinder& finder, std::uint32_t n,
                                                   int warm_up = 2) {
  cuda_emulation::ApiCounters before;
  for (int frame = 0; frame <= warm_up; ++frame) {
    const std::vector<ObjectBounds> boxes = steppingBoxes(n, frame);
    std::span<const ObjectBounds> passed = boxes;
    if (const std::span<ObjectBounds> staging = finder.stagingFor(n); !staging.empty()) {
      std::copy(boxes.begin(), boxes.end(), staging.begin());
      passed = staging;
    }
    if (frame == warm_up) before = cuda_emulation::apiCounters();
    finder.launch(passed);
    finder.finish();
  }
  return cuda_emulation::apiCounters() - before;
}

}  // namespace overlap::finders::testing
