// Force-included (-include) before every Broadmark source the peer build
// compiles: the few MSVC names Broadmark's CPU broadphases use, mapped onto
// Linux.  Broadmark's files are compiled as they are; this header adds, never
// changes, their code.  __declspec(align(n)) itself is left to clang's
// -fdeclspec, which keeps its meaning (scripts/peers/CMakeLists.txt).
#pragma once

#include <cstdlib>
#include <cstring>

#define __forceinline inline __attribute__((always_inline))

// MSVC's aligned heap pair: memory from _aligned_malloc goes back through
// _aligned_free only, so posix_memalign and free are an exact match.
inline void* _aligned_malloc(std::size_t size, std::size_t alignment) {
  void* memory = nullptr;
  return posix_memalign(&memory, alignment < sizeof(void*) ? sizeof(void*) : alignment, size) == 0
             ? memory
             : nullptr;
}
inline void _aligned_free(void* memory) {
  std::free(memory);
}
