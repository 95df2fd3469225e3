// What the CUDA emulation's CUB stand-ins share (see cub/cub.cuh): the
// temporary-storage protocol and running a closure in a stream's order.
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <cstring>
#include <functional>
#include <memory>
#include <utility>

namespace cub::emulation {

inline constexpr unsigned char kGarbage = 0xA5;  // what the emulated device's memory starts as

// CUB's two-phase protocol: with no storage, report what is needed; with too
// little, fail; otherwise enqueue `work` on `stream`, first overwriting the
// whole temporary storage (the caller must not rely on its contents, and an
// undersized allocation is a visible out-of-bounds write).
inline cudaError_t runWithTempStorage(void* d_temp_storage, std::size_t& temp_storage_bytes,
                                      std::size_t needed, cudaStream_t stream,
                                      std::function<void()> work) {
  if (d_temp_storage == nullptr) {
    temp_storage_bytes = needed;
    return cudaSuccess;
  }
  if (temp_storage_bytes < needed) return cudaErrorInvalidValue;
  auto closure =
      std::make_unique<std::function<void()>>([d_temp_storage, needed, work = std::move(work)] {
        std::memset(d_temp_storage, kGarbage, needed);
        work();
      });
  const cudaError_t status = cudaLaunchHostFunc(
      stream,
      [](void* user_data) {
        const std::unique_ptr<std::function<void()>> run(
            static_cast<std::function<void()>*>(user_data));
        (*run)();
      },
      closure.get());
  if (status == cudaSuccess) closure.release();  // the stream owns it now
  return status;
}

// A fixed temporary size for the algorithms whose real storage is a few
// tiles' state: enough to make a caller allocate and pass it.
inline constexpr std::size_t kSmallTempStorageBytes = 256;

}  // namespace cub::emulation
