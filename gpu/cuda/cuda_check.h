// CUDA error checking for the GPU finders (nvcc only).  Every runtime call
// goes through CUDA_CHECK, which throws std::runtime_error naming the call,
// the file and line, and CUDA's own description of the error;
// CUDA_CHECK_COUNTED also counts the call, for a finder's count of the calls
// a frame makes (DeviceWork::api_calls).  A helper that makes a call for its
// caller (a launch, a CUB call) takes the caller's std::source_location and
// checks with checkCuda(), so that the error names the caller's line.
#pragma once

#include <cuda_runtime.h>

#include <source_location>
#include <stdexcept>
#include <string>

namespace overlap::finders {

[[noreturn]] inline void throwCudaError(cudaError_t error, const char* call, const char* file,
                                        int line) {
  throw std::runtime_error(std::string(file) + ":" + std::to_string(line) + ": " + call +
                           " failed: " + cudaGetErrorName(error) + ": " +
                           cudaGetErrorString(error));
}

inline void checkCuda(cudaError_t error, const char* call, std::source_location where) {
  if (error != cudaSuccess)
    throwCudaError(error, call, where.file_name(), static_cast<int>(where.line()));
}

}  // namespace overlap::finders

#define CUDA_CHECK(call)                                                                  \
  do {                                                                                    \
    const cudaError_t overlap_cuda_status = (call);                                       \
    if (overlap_cuda_status != cudaSuccess) {                                             \
      ::overlap::finders::throwCudaError(overlap_cuda_status, #call, __FILE__, __LINE__); \
    }                                                                                     \
  } while (false)

#define CUDA_CHECK_COUNTED(counter, call) \
  do {                                    \
    ++(counter);                          \
    CUDA_CHECK(call);                     \
  } while (false)
