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
void* operator new(std::size_t bytes, std::align_val_t alignment) {
  const auto align = static_cast<std::size_t>(alignment);
  void* memory =
      std::aligned_alloc(align, (std::max<std::size_t>(bytes, 1) + align - 1) / align * align);
  if (memory == nullptr) throw std::bad_alloc();
  note(static_cast<std::int64_t>(malloc_usable_size(memory)));
  return memory;
}
void* operator new[](std::size_t bytes, std::align_val_t alignment) {
  return operator new(bytes, alignment);
}
void operator delete(void* memory, std::align_val_t) noexcept {
  countedRelease(memory);
}
void operator delete[](void* memory, std::align_val_t) noexcept {
  countedRelease(memory);
}
void operator delete(void* memory, std::size_t, std::align_val_t) noexcept {
  countedRelease(memory);
}
void operator delete[](void* memory, std::size_t, std::align_val_t) noexcept {
  countedRelease(memory);
}

namespace overlap::test_support {

std::int64_t heapLive() {
  return g_live.load();
}

std::int64_t takeHeapPeak() {
  return g_peak.exchange(g_live.load());
}

}  // namespace overlap::test_support
