// The device side of the CUDA emulation: the built-in coordinates
// (threadIdx, blockIdx, blockDim, gridDim), warp collectives, __syncthreads,
// atomics and bit intrinsics, for kernels compiled by the host compiler.
//
// Each CUDA thread runs as a fiber (gpu/emulation/executor.cpp), so the
// coordinates are the running fiber's.  A collective suspends its fiber until
// every lane its mask names has arrived at a collective of the same kind and
// mask; then all of them get their results.  Atomics are std::atomic_ref, as
// the blocks of a grid run on several OS threads at once.
#pragma once

#include <atomic>
#include <bit>
#include <cstdint>
#include <cstring>
#include <functional>
#include <source_location>
#include <type_traits>

namespace overlap::cuda_emulation {

// What a thread knows about itself; the executor points the OS thread's
// current pointer at the running fiber's copy.
struct ThreadCoordinates {
  uint3 thread_idx;
  uint3 block_idx;
  dim3 block_dim;
  dim3 grid_dim;
};

enum class Collective {
  kSyncThreads,
  kSyncWarp,
  kBallot,
  kAny,
  kAll,
  kShfl,
  kShflUp,
  kShflDown,
  kShflXor
};

namespace detail {

// The running fiber's coordinates; aborts naming the misuse when no kernel
// thread is running on this OS thread.  A call, not the thread_local itself:
// a kernel's translation unit then never addresses executor.cpp's
// thread_local.  (Addressed from here, GCC 12 with -fsanitize=null tested the
// variable's address using the flags of an `add x@gottpoff(%rip)`, which the
// linker rewrites into a flag-less `lea` in an executable, so the check read
// stale flags and reported a null pointer where there was none.)
const ThreadCoordinates& coordinates();

// Waits, in the running fiber, for the lanes of `mask` (or for the block) and
// returns this lane's result: the ballot, the any/all flag, or the shuffled
// value's bits.  `operand` is the source lane, delta or lane mask of a shuffle.
std::uint64_t collective(Collective kind, unsigned mask, std::uint64_t value, int operand,
                         int width, const std::source_location& site);

template <class T>
std::uint64_t toBits(T value) {
  static_assert(std::is_trivially_copyable_v<T> && sizeof(T) <= sizeof(std::uint64_t),
                "a shuffled value must be a scalar of at most 8 bytes");
  std::uint64_t bits = 0;
  std::memcpy(&bits, &value, sizeof(T));
  return bits;
}

template <class T>
T fromBits(std::uint64_t bits) {
  T value;
  std::memcpy(&value, &bits, sizeof(T));
  return value;
}

template <class T>
T shuffle(Collective kind, unsigned mask, T value, int operand, int width,
          const std::source_location& site) {
  return fromBits<T>(collective(kind, mask, toBits(value), operand, width, site));
}

// Stores `value` while `replace(old, value)` holds; returns the old value.
template <class T, class Replace>
T replaceWhile(T* address, T value, Replace replace) {
  std::atomic_ref<T> target(*address);
  T old = target.load(std::memory_order_relaxed);
  while (replace(old, value) &&
         !target.compare_exchange_weak(old, value, std::memory_order_relaxed)) {
  }
  return old;
}

}  // namespace detail
}  // namespace overlap::cuda_emulation

#define threadIdx (::overlap::cuda_emulation::detail::coordinates().thread_idx)
#define blockIdx (::overlap::cuda_emulation::detail::coordinates().block_idx)
#define blockDim (::overlap::cuda_emulation::detail::coordinates().block_dim)
#define gridDim (::overlap::cuda_emulation::detail::coordinates().grid_dim)
inline constexpr int warpSize = 32;

inline void __syncthreads(std::source_location site = std::source_location::current()) {
  ::overlap::cuda_emulation::detail::collective(::overlap::cuda_emulation::Collective::kSyncThreads,
                                                0, 0, 0, 0, site);
}

inline void __syncwarp(unsigned mask = 0xFFFFFFFFu,
                       std::source_location site = std::source_location::current()) {
  ::overlap::cuda_emulation::detail::collective(::overlap::cuda_emulation::Collective::kSyncWarp,
                                                mask, 0, 0, 32, site);
}

inline unsigned __ballot_sync(unsigned mask, int predicate,
                              std::source_location site = std::source_location::current()) {
  return static_cast<unsigned>(::overlap::cuda_emulation::detail::collective(
      ::overlap::cuda_emulation::Collective::kBallot, mask, predicate != 0, 0, 32, site));
}

inline int __any_sync(unsigned mask, int predicate,
                      std::source_location site = std::source_location::current()) {
  return static_cast<int>(::overlap::cuda_emulation::detail::collective(
      ::overlap::cuda_emulation::Collective::kAny, mask, predicate != 0, 0, 32, site));
}

inline int __all_sync(unsigned mask, int predicate,
                      std::source_location site = std::source_location::current()) {
  return static_cast<int>(::overlap::cuda_emulation::detail::collective(
      ::overlap::cuda_emulation::Collective::kAll, mask, predicate != 0, 0, 32, site));
}

template <class T>
T __shfl_sync(unsigned mask, T value, int source_lane, int width = 32,
              std::source_location site = std::source_location::current()) {
  return ::overlap::cuda_emulation::detail::shuffle(::overlap::cuda_emulation::Collective::kShfl,
                                                    mask, value, source_lane, width, site);
}

template <class T>
T __shfl_up_sync(unsigned mask, T value, unsigned delta, int width = 32,
                 std::source_location site = std::source_location::current()) {
  return ::overlap::cuda_emulation::detail::shuffle(::overlap::cuda_emulation::Collective::kShflUp,
                                                    mask, value, static_cast<int>(delta), width,
                                                    site);
}

template <class T>
T __shfl_down_sync(unsigned mask, T value, unsigned delta, int width = 32,
                   std::source_location site = std::source_location::current()) {
  return ::overlap::cuda_emulation::detail::shuffle(
      ::overlap::cuda_emulation::Collective::kShflDown, mask, value, static_cast<int>(delta), width,
      site);
}

template <class T>
T __shfl_xor_sync(unsigned mask, T value, int lane_mask, int width = 32,
                  std::source_location site = std::source_location::current()) {
  return ::overlap::cuda_emulation::detail::shuffle(::overlap::cuda_emulation::Collective::kShflXor,
                                                    mask, value, lane_mask, width, site);
}

inline int __popc(unsigned x) {
  return std::popcount(x);
}
inline int __popcll(unsigned long long x) {
  return std::popcount(x);
}
inline int __clz(int x) {
  return std::countl_zero(static_cast<unsigned>(x));
}
inline int __clzll(long long x) {
  return std::countl_zero(static_cast<unsigned long long>(x));
}
inline int __ffs(int x) {
  return x == 0 ? 0 : std::countr_zero(static_cast<unsigned>(x)) + 1;
}
inline int __ffsll(long long x) {
  return x == 0 ? 0 : std::countr_zero(static_cast<unsigned long long>(x)) + 1;
}

// A fence for the whole device: this thread's writes before it are seen
// before its writes after it (with the atomics below, the last-block pattern).
inline void __threadfence() {
  std::atomic_thread_fence(std::memory_order_seq_cst);
}

// Atomics return the old value, as on the device.
template <class T>
T atomicAdd(T* address, std::type_identity_t<T> value) {
  return std::atomic_ref<T>(*address).fetch_add(value, std::memory_order_relaxed);
}

template <class T>
T atomicSub(T* address, std::type_identity_t<T> value) {
  return std::atomic_ref<T>(*address).fetch_sub(value, std::memory_order_relaxed);
}

template <class T>
T atomicExch(T* address, std::type_identity_t<T> value) {
  return std::atomic_ref<T>(*address).exchange(value, std::memory_order_relaxed);
}

template <class T>
T atomicCAS(T* address, std::type_identity_t<T> expected, std::type_identity_t<T> desired) {
  std::atomic_ref<T>(*address).compare_exchange_strong(expected, desired,
                                                       std::memory_order_relaxed);
  return expected;
}

template <class T>
T atomicMax(T* address, std::type_identity_t<T> value) {
  return ::overlap::cuda_emulation::detail::replaceWhile(address, value, std::less<T>());
}

template <class T>
T atomicMin(T* address, std::type_identity_t<T> value) {
  return ::overlap::cuda_emulation::detail::replaceWhile(address, value, std::greater<T>());
}
