// Owning handles for CUDA memory (nvcc only): device buffers and pinned host
// buffers that free themselves, move but never copy, and grow geometrically
// so that a finder allocates a handful of times per run, never per frame.
#pragma once

#include <cuda_runtime.h>

#include <algorithm>
#include <cstddef>
#include <utility>

#include "gpu/cuda/cuda_check.h"

namespace overlap::finders {

enum class MemorySpace { kDevice, kPinnedHost };

template <class T, MemorySpace kSpace>
class CudaBuffer {
 public:
  CudaBuffer() = default;
  explicit CudaBuffer(std::size_t count) : count_(count) {
    if (count == 0) return;
    void* memory = nullptr;
    if constexpr (kSpace == MemorySpace::kDevice) {
      CUDA_CHECK(cudaMalloc(&memory, count * sizeof(T)));
    } else {
      CUDA_CHECK(cudaMallocHost(&memory, count * sizeof(T)));
    }
    data_ = static_cast<T*>(memory);
  }
  CudaBuffer(CudaBuffer&& other) noexcept
      : data_(std::exchange(other.data_, nullptr)), count_(std::exchange(other.count_, 0)) {}
  // Frees what this buffer held, then takes `other`'s memory (never a swap).
  CudaBuffer& operator=(CudaBuffer&& other) noexcept {
    if (this != &other) {
      release();
      data_ = std::exchange(other.data_, nullptr);
      count_ = std::exchange(other.count_, 0);
    }
    return *this;
  }
  CudaBuffer(const CudaBuffer&) = delete;
  CudaBuffer& operator=(const CudaBuffer&) = delete;
  ~CudaBuffer() { release(); }

  T* data() const { return data_; }
  std::size_t size() const { return count_; }

 private:
  // Freeing cannot report an error from a destructor; a failure here means the
  // context is already lost, which the next checked call reports.  cudaFree
  // waits for the device, so no queued work still uses the memory.
  void release() noexcept {
    if (data_ == nullptr) return;
    if constexpr (kSpace == MemorySpace::kDevice) {
      cudaFree(data_);
    } else {
      cudaFreeHost(data_);
    }
    data_ = nullptr;
    count_ = 0;
  }

  T* data_ = nullptr;
  std::size_t count_ = 0;
};

template <class T>
using DeviceBuffer = CudaBuffer<T, MemorySpace::kDevice>;
template <class T>
using PinnedBuffer = CudaBuffer<T, MemorySpace::kPinnedHost>;

// Room for `needed` elements, at least doubling; the old contents are dropped.
// Returns whether it reallocated.
template <class T, MemorySpace kSpace>
bool reserveDiscarding(CudaBuffer<T, kSpace>& buffer, std::size_t needed) {
  if (needed <= buffer.size()) return false;
  const std::size_t grown = std::max(needed, 2 * buffer.size());
  buffer = CudaBuffer<T, kSpace>();  // free first: the old contents are not needed
  buffer = CudaBuffer<T, kSpace>(grown);
  return true;
}

}  // namespace overlap::finders
