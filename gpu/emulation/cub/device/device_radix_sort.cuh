// The CUDA emulation's cub::DeviceRadixSort (see cub/cub.cuh): SortPairs and
// SortKeys, from pointers or DoubleBuffers, on bits [begin_bit, end_bit) of
// unsigned integer keys, stable, on the CPU in the stream's order; and
// SortKeys of a DoubleBuffer of any key type through a decomposer (CUB's
// form: a tuple of references to the key's unsigned members, the first the
// most significant, their bits concatenated; at most 64 bits in all here).
//
// A DoubleBuffer sort ends in the buffer its pass count says, as CUB's does:
// one pass per kDigitBits of the bit range, each pass moving the data to the
// other buffer; the other buffer is left holding garbage.  Callers read
// Current() and never assume which buffer that is.
#pragma once

#include <algorithm>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <cuda/std/tuple>
#include <numeric>
#include <type_traits>
#include <vector>

#include "cub/host_work.h"
#include "cub/util_type.cuh"

namespace cub {
namespace emulation {

inline constexpr int kDigitBits = 7;

inline int passCount(int begin_bit, int end_bit) {
  return end_bit > begin_bit ? (end_bit - begin_bit + kDigitBits - 1) / kDigitBits : 0;
}

template <class Key>
Key keyBits(Key key, int begin_bit, int end_bit) {
  if (end_bit <= begin_bit) return 0;
  const int width = end_bit - begin_bit;
  const Key shifted = static_cast<Key>(key >> begin_bit);
  return width >= static_cast<int>(sizeof(Key) * 8)
             ? shifted
             : static_cast<Key>(shifted & ((Key{1} << width) - 1));
}

// A key as its radix bits: itself, unless a decomposer names its members.
struct IdentityBits {
  template <std::unsigned_integral Key>
  Key operator()(const Key& key) const {
    return key;
  }
};

// A decomposed key's members, concatenated into one unsigned integer.
template <class Split>
struct ConcatenatedBits {
  Split decomposer;
  template <class Key>
  std::uint64_t operator()(const Key& key) const {
    Key copy = key;  // the decomposer takes a non-const reference, and reads it only
    return std::apply(
        [](auto&... members) {
          static_assert((std::unsigned_integral<std::remove_cvref_t<decltype(members)>> && ...));
          static_assert((sizeof(members) + ...) <= sizeof(std::uint64_t));
          std::uint64_t bits = 0;
          ((bits = (sizeof(members) == 8 ? 0 : bits << (8 * sizeof(members))) | members), ...);
          return bits;
        },
        decomposer(copy));
  }
};

// The order a stable sort by the bit range of each key's radix bits puts
// keys[0..count) in.
template <class Key, class Bits = IdentityBits>
std::vector<std::size_t> sortedOrder(const Key* keys, std::size_t count, int begin_bit, int end_bit,
                                     Bits bits = {}) {
  std::vector<std::size_t> order(count);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    return keyBits(bits(keys[x]), begin_bit, end_bit) < keyBits(bits(keys[y]), begin_bit, end_bit);
  });
  return order;
}

// Sorts keys (and values, when not null) from `*_in` to `*_out`; in and out
// may be the same memory (the inputs are read whole first).
template <class Key, class Value, class Bits = IdentityBits>
void sortInto(const Key* keys_in, Key* keys_out, const Value* values_in, Value* values_out,
              std::size_t count, int begin_bit, int end_bit, Bits bits = {}) {
  const std::vector<std::size_t> order = sortedOrder(keys_in, count, begin_bit, end_bit, bits);
  const std::vector<Key> keys(keys_in, keys_in + count);
  for (std::size_t i = 0; i < count; ++i) keys_out[i] = keys[order[i]];
  if (values_in == nullptr) return;
  const std::vector<Value> values(values_in, values_in + count);
  for (std::size_t i = 0; i < count; ++i) values_out[i] = values[order[i]];
}

template <class Key>
concept RadixKey = std::unsigned_integral<Key>;

// What CUB takes for a decomposer: anything that is not a bit index.
template <class T>
concept Decomposer = !std::is_convertible_v<T, int>;

// The validity CUB checks on the host before it enqueues anything.
template <class Key>
bool validBits(int begin_bit, int end_bit) {
  return begin_bit >= 0 && end_bit <= static_cast<int>(sizeof(Key) * 8) && begin_bit <= end_bit;
}

// The pointer forms need room for the alternate buffers CUB allocates for them.
template <class Key, class Value>
std::size_t pointerFormTempBytes(std::size_t count) {
  return kSmallTempStorageBytes + count * (sizeof(Key) + sizeof(Value));
}

template <class Key, class Value>
cudaError_t sortPointers(void* d_temp_storage, std::size_t& temp_storage_bytes, const Key* keys_in,
                         Key* keys_out, const Value* values_in, Value* values_out,
                         std::size_t count, int begin_bit, int end_bit, cudaStream_t stream) {
  if (!validBits<Key>(begin_bit, end_bit)) return cudaErrorInvalidValue;
  return runWithTempStorage(
      d_temp_storage, temp_storage_bytes, pointerFormTempBytes<Key, Value>(count), stream,
      [=] { sortInto(keys_in, keys_out, values_in, values_out, count, begin_bit, end_bit); });
}

template <class Key, class Value, class Bits = IdentityBits>
cudaError_t sortDoubleBuffers(void* d_temp_storage, std::size_t& temp_storage_bytes,
                              DoubleBuffer<Key>& keys, DoubleBuffer<Value>* values,
                              std::size_t count, int begin_bit, int end_bit, cudaStream_t stream,
                              Bits bits = {}) {
  if (!validBits<Key>(begin_bit, end_bit)) return cudaErrorInvalidValue;
  const bool moves = passCount(begin_bit, end_bit) % 2 == 1 && count > 0;
  Key* const keys_from = keys.Current();
  Key* const keys_to = moves ? keys.Alternate() : keys.Current();
  Value* const values_from = values != nullptr ? values->Current() : nullptr;
  Value* const values_to =
      values == nullptr ? nullptr : (moves ? values->Alternate() : values->Current());
  const cudaError_t status =
      runWithTempStorage(d_temp_storage, temp_storage_bytes, kSmallTempStorageBytes, stream, [=] {
        sortInto(keys_from, keys_to, values_from, values_to, count, begin_bit, end_bit, bits);
        if (!moves) return;
        std::memset(static_cast<void*>(keys_from), kGarbage, count * sizeof(Key));
        if (values_from != nullptr) {
          std::memset(static_cast<void*>(values_from), kGarbage, count * sizeof(Value));
        }
      });
  if (status == cudaSuccess && d_temp_storage != nullptr && moves) {
    keys.selector ^= 1;
    if (values != nullptr) values->selector ^= 1;
  }
  return status;
}

}  // namespace emulation

struct DeviceRadixSort {
  template <emulation::RadixKey KeyT, class ValueT, class NumItemsT>
  static cudaError_t SortPairs(void* d_temp_storage, std::size_t& temp_storage_bytes,
                               const KeyT* d_keys_in, KeyT* d_keys_out, const ValueT* d_values_in,
                               ValueT* d_values_out, NumItemsT num_items, int begin_bit = 0,
                               int end_bit = sizeof(KeyT) * 8, cudaStream_t stream = 0) {
    return emulation::sortPointers(d_temp_storage, temp_storage_bytes, d_keys_in, d_keys_out,
                                   d_values_in, d_values_out, static_cast<std::size_t>(num_items),
                                   begin_bit, end_bit, stream);
  }

  template <emulation::RadixKey KeyT, class ValueT, class NumItemsT>
  static cudaError_t SortPairs(void* d_temp_storage, std::size_t& temp_storage_bytes,
                               DoubleBuffer<KeyT>& d_keys, DoubleBuffer<ValueT>& d_values,
                               NumItemsT num_items, int begin_bit = 0,
                               int end_bit = sizeof(KeyT) * 8, cudaStream_t stream = 0) {
    return emulation::sortDoubleBuffers(d_temp_storage, temp_storage_bytes, d_keys, &d_values,
                                        static_cast<std::size_t>(num_items), begin_bit, end_bit,
                                        stream);
  }

  template <emulation::RadixKey KeyT, class NumItemsT>
  static cudaError_t SortKeys(void* d_temp_storage, std::size_t& temp_storage_bytes,
                              const KeyT* d_keys_in, KeyT* d_keys_out, NumItemsT num_items,
                              int begin_bit = 0, int end_bit = sizeof(KeyT) * 8,
                              cudaStream_t stream = 0) {
    return emulation::sortPointers<KeyT, KeyT>(
        d_temp_storage, temp_storage_bytes, d_keys_in, d_keys_out, nullptr, nullptr,
        static_cast<std::size_t>(num_items), begin_bit, end_bit, stream);
  }

  template <emulation::RadixKey KeyT, class NumItemsT>
  static cudaError_t SortKeys(void* d_temp_storage, std::size_t& temp_storage_bytes,
                              DoubleBuffer<KeyT>& d_keys, NumItemsT num_items, int begin_bit = 0,
                              int end_bit = sizeof(KeyT) * 8, cudaStream_t stream = 0) {
    return emulation::sortDoubleBuffers<KeyT, KeyT>(d_temp_storage, temp_storage_bytes, d_keys,
                                                    nullptr, static_cast<std::size_t>(num_items),
                                                    begin_bit, end_bit, stream);
  }

  template <class KeyT, class NumItemsT, emulation::Decomposer DecomposerT>
  static cudaError_t SortKeys(void* d_temp_storage, std::size_t& temp_storage_bytes,
                              DoubleBuffer<KeyT>& d_keys, NumItemsT num_items,
                              DecomposerT decomposer, int begin_bit, int end_bit,
                              cudaStream_t stream = 0) {
    return emulation::sortDoubleBuffers<KeyT, KeyT>(
        d_temp_storage, temp_storage_bytes, d_keys, nullptr, static_cast<std::size_t>(num_items),
        begin_bit, end_bit, stream, emulation::ConcatenatedBits<DecomposerT>{decomposer});
  }
};

}  // namespace cub
