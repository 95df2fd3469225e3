// FNV-1a checksums, so determinism tests can compare whole buffers by one
// number: the physics state hash and the stubs' outputs use it.
//
// The hash covers the values' object bytes, so it is only as portable as their
// representation: equal on machines with the same endianness and float format,
// which is every machine this project runs on.  Not a cryptographic hash.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>

namespace overlap {

inline constexpr std::uint64_t kFnv1aOffsetBasis = 14695981039346656037ull;
inline constexpr std::uint64_t kFnv1aPrime = 1099511628211ull;

// Continues the hash `state` over `bytes`; chain calls to hash several buffers.
inline std::uint64_t fnv1a(std::span<const std::byte> bytes,
                           std::uint64_t state = kFnv1aOffsetBasis) {
  for (const std::byte byte : bytes) {
    state ^= static_cast<std::uint64_t>(byte);
    state *= kFnv1aPrime;
  }
  return state;
}

template <typename T>
requires std::is_trivially_copyable_v<T> std::uint64_t fnv1a(
    std::span<const T> values, std::uint64_t state = kFnv1aOffsetBasis) {
  return fnv1a(std::as_bytes(values), state);
}

}  // namespace overlap
