// The CUDA emulation's cub::BlockRadixSort (see cub/cub.cuh): a block-wide
// collective that sorts the block's keys, ITEMS_PER_THREAD a thread in
// blocked order (thread t holds ranks t * ITEMS_PER_THREAD onwards), by bits
// [begin_bit, end_bit) alone, stably, as CUB's Sort does.
//
// Contracts kept, each as CUB states it:
// - every thread of the block calls Sort(), with the same bit range: it is a
//   collective, and waits for the whole block (__syncthreads), so a thread
//   that skips it stops the emulation with the call site;
// - TempStorage is the block's shared memory for one sort at a time: reusing
//   it needs a __syncthreads() after the last thread has read its keys back.
// Keys are unsigned integers only; values, descending sorts and the striped
// variants are absent.
#pragma once

#include <cuda_runtime.h>

#include <algorithm>
#include <climits>
#include <cstdint>
#include <type_traits>

namespace cub {

template <class KeyT, int BLOCK_DIM_X, int ITEMS_PER_THREAD>
class BlockRadixSort {
  static_assert(std::is_unsigned_v<KeyT>, "the stand-in sorts unsigned integer keys only");

 public:
  struct TempStorage {
    KeyT keys[BLOCK_DIM_X * ITEMS_PER_THREAD];
  };

  __device__ explicit BlockRadixSort(TempStorage& storage) : storage_(storage) {}

  __device__ void Sort(KeyT (&keys)[ITEMS_PER_THREAD], int begin_bit = 0,
                       int end_bit = sizeof(KeyT) * CHAR_BIT) {
    const unsigned first = threadIdx.x * ITEMS_PER_THREAD;
    for (int item = 0; item < ITEMS_PER_THREAD; ++item) storage_.keys[first + item] = keys[item];
    __syncthreads();
    if (threadIdx.x == 0) {
      const auto digits = [=](KeyT key) { return bitsOf(key, begin_bit, end_bit); };
      std::stable_sort(std::begin(storage_.keys), std::end(storage_.keys),
                       [&](KeyT x, KeyT y) { return digits(x) < digits(y); });
    }
    __syncthreads();
    for (int item = 0; item < ITEMS_PER_THREAD; ++item) keys[item] = storage_.keys[first + item];
  }

 private:
  static KeyT bitsOf(KeyT key, int begin_bit, int end_bit) {
    constexpr int kBits = sizeof(KeyT) * CHAR_BIT;
    const KeyT shifted = begin_bit >= kBits ? KeyT{0} : static_cast<KeyT>(key >> begin_bit);
    const int width = end_bit - begin_bit;
    if (width <= 0) return 0;
    if (width >= kBits) return shifted;
    return static_cast<KeyT>(shifted & ((KeyT{1} << width) - 1));
  }

  TempStorage& storage_;
};

}  // namespace cub
