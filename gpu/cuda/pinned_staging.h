// Pinned staging for a GPU finder's boxes (nvcc and the emulation only): the
// room stagingFor() lends the caller, and the copy launch() makes when the
// caller passed its own (pageable) memory instead.  Pinned, so the upload
// that follows is asynchronous; it grows geometrically and never shrinks.
#pragma once

#include <cstddef>
#include <cstring>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

#include "gpu/cuda/cuda_buffers.h"
#include "gpu/pair_finder.h"

namespace overlap::finders {

class PinnedStaging {
 public:
  // PairFinder::stagingFor(): room for `count` boxes, lent only between
  // frames (a search in flight may still read it).
  std::span<ObjectBounds> room(std::string_view finder, bool in_flight, std::size_t count) {
    if (in_flight) {
      throw std::runtime_error(std::string(finder) +
                               ": stagingFor() called between launch() and finish()");
    }
    reserveDiscarding(boxes_, count);
    return {boxes_.data(), count};
  }

  // Makes `objects` this frame's staged boxes: nothing to do when the caller
  // filled room(), else a copy (the caller's memory may change once launch()
  // returns).  Returns the bytes copied on the host.
  std::size_t stage(std::span<const ObjectBounds> objects) {
    if (objects.empty() || objects.data() == boxes_.data()) return 0;
    reserveDiscarding(boxes_, objects.size());
    std::memcpy(boxes_.data(), objects.data(), objects.size_bytes());
    return objects.size_bytes();
  }

  const ObjectBounds* data() const { return boxes_.data(); }

 private:
  PinnedBuffer<ObjectBounds> boxes_;
};

}  // namespace overlap::finders
