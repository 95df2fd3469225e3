#include "tests/counted_heap.h"

#include <malloc.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <new>

namespace {

std::atomic<std::int64_t> g_live{0};
std::atomic<std::int64_t> g_peak{0};

void note(std::int64_t change) {
  const std::int64_t live = g_live += change;
  std::int64_t peak = g_peak.load();
  while (live > peak && !g_peak.compare_exchange_weak(peak, live)) {
  }
}

}  // namespace

namespace overlap::test_support {

void* countedAllocation(std::size_t bytes) {
  void* memory = std::malloc(std::max<std::size_t>(bytes, 1));
  if (memory == nullptr) throw std::bad_alloc();
  note(static_cast<std::int64_t>(malloc_usable_size(memory)));
  return memory;
}

void countedRelease(void* memory) noexcept {
  if (memory == nullptr) return;
  note(-static_cast<std::int64_t>(malloc_usable_size(memory)));
  std::free(memory);
}

}  // namespace overlap::test_support

using overlap::test_support::countedAllocation;
using overlap::test_support::countedRelease;

void* operator new(std::size_t bytes) {
  return countedAllocation(bytes);
}
void* operator new[](std::size_t bytes) {
  return countedAllocation(bytes);
}
void operator delete(void* memory) noexcept {
  countedRelease(memory);
}
void operator delete[](void* memory) noexcept {
  countedRelease(memory);
}
void operator delete(void* memory, std::size_t) noexcept {
  countedRelease(memory);
}
void operator delete[](void* memory, std::size_t) noexcept {
  countedRelease(memory);
}
void* operator new(std::size_t bytes, const std::nothrow_t&) noexcept {
  try {
    return countedAllocation(bytes);
  } catch (const std::bad_alloc&) {
    return nullptr;
  }
}
void* operator new[](std::size_t bytes, const std::nothrow_t& nothrow) noexcept {
  return operator new(bytes, nothrow);
}
void operator delete(void* memory, const std::nothrow_t&) noexcept {
  countedRelease(memory);
}
void operator delete[](void* memory, const std::nothrow_t&) noexcept {
  countedRelease(memory);
}
// Aligned allocations count the bytes asked for: glibc gives a large one
// (cpusap's and the pair cache's 2 MiB-aligned arrays) a mapping whose usable
// size depends on where the alignment fell, anywhere up to 2 MiB more.  The
// count sits in the alignment's room before the block.
namespace {

void* countedAligned(std::size_t bytes, std::align_val_t alignment) {
  const std::size_t align = std::max(static_cast<std::size_t>(alignment), sizeof(std::size_t));
  const std::size_t size = (std::max<std::size_t>(bytes, 1) + align - 1) / align * align;
  auto* base = static_cast<unsigned char*>(std::aligned_alloc(align, align + size));
  if (base == nullptr) throw std::bad_alloc();
  unsigned char* memory = base + align;
  reinterpret_cast<std::size_t*>(memory)[-1] = size;
  note(static_cast<std::int64_t>(size));
  return memory;
}

void releaseAligned(void* memory, std::align_val_t alignment) noexcept {
  if (memory == nullptr) return;
  const std::size_t align = std::max(static_cast<std::size_t>(alignment), sizeof(std::size_t));
  note(-static_cast<std::int64_t>(static_cast<std::size_t*>(memory)[-1]));
  std::free(static_cast<unsigned char*>(memory) - align);
}

}  // namespace

void* operator new(std::size_t bytes, std::align_val_t alignment) {
  return countedAligned(bytes, alignment);
}
void* operator new[](std::size_t bytes, std::align_val_t alignment) {
  return countedAligned(bytes, alignment);
}
void operator delete(void* memory, std::align_val_t alignment) noexcept {
  releaseAligned(memory, alignment);
}
void operator delete[](void* memory, std::align_val_t alignment) noexcept {
  releaseAligned(memory, alignment);
}
void operator delete(void* memory, std::size_t, std::align_val_t alignment) noexcept {
  releaseAligned(memory, alignment);
}
void operator delete[](void* memory, std::size_t, std::align_val_t alignment) noexcept {
  releaseAligned(memory, alignment);
}
void* operator new(std::size_t bytes, std::align_val_t alignment, const std::nothrow_t&) noexcept {
  try {
    return countedAligned(bytes, alignment);
  } catch (const std::bad_alloc&) {
    return nullptr;
  }
}
void* operator new[](std::size_t bytes, std::align_val_t alignment,
                     const std::nothrow_t& nothrow) noexcept {
  return operator new(bytes, alignment, nothrow);
}
void operator delete(void* memory, std::align_val_t alignment, const std::nothrow_t&) noexcept {
  releaseAligned(memory, alignment);
}
void operator delete[](void* memory, std::align_val_t alignment, const std::nothrow_t&) noexcept {
  releaseAligned(memory, alignment);
}

namespace overlap::test_support {

std::int64_t heapLive() {
  return g_live.load();
}

std::int64_t takeHeapPeak() {
  return g_peak.exchange(g_live.load());
}

}  // namespace overlap::test_support
