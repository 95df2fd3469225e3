// The heap a test executable holds, counted: tests/counted_heap.cpp replaces
// operator new and delete (link it only into an executable of memory tests);
// a test hands Bullet countedAllocation and countedRelease
// (btAlignedAllocSetCustom) before it makes any Bullet object.  Counts are
// usable sizes, so the allocator's rounding is in; an aligned allocation
// counts the bytes it asked for, rounded to its alignment.
#pragma once

#include <cstddef>
#include <cstdint>

namespace overlap::test_support {

// The bytes allocated and not yet freed.
std::int64_t heapLive();
// The most heapLive() has been since the last call, which starts the next
// span at the live bytes.
std::int64_t takeHeapPeak();
// malloc and free, counted; countedAllocation throws std::bad_alloc.
void* countedAllocation(std::size_t bytes);
void countedRelease(void* memory) noexcept;

}  // namespace overlap::test_support
