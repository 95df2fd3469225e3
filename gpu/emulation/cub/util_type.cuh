// The CUDA emulation's cub::DoubleBuffer (see cub/cub.cuh): two buffers of one
// size and a selector naming the one that holds the valid data, as in CUB.
#pragma once

namespace cub {

template <class T>
struct DoubleBuffer {
  T* d_buffers[2]{};
  int selector = 0;

  DoubleBuffer() = default;
  DoubleBuffer(T* d_current, T* d_alternate) : d_buffers{d_current, d_alternate} {}

  T* Current() { return d_buffers[selector]; }
  T* Alternate() { return d_buffers[selector ^ 1]; }
};

}  // namespace cub
