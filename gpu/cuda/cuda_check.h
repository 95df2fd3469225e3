// CUDA error checking, the one check of the GPU code (nvcc and the
// emulation only).  Every runtime call goes through checkCuda(), which throws
// std::runtime_error naming the call, the caller's file and line, and CUDA's
// own description of the error, and consumes it (the next check reports
// only what happens after it): CUDA_CHECK(call) names the call's text and
// line; a helper that makes a call for its caller (FinderDevice, which also
// counts it in DeviceWork::api_calls) takes the caller's std::source_location
// and passes it on, so that the error names the caller's line, not its own.
#pragma once

#include <cuda_runtime.h>

#include <source_location>
#include <stdexcept>
#include <string>

namespace overlap::finders {

inline void checkCuda(cudaError_t error, const char* call,
                      std::source_location where = std::source_location::current()) {
  if (error == cudaSuccess) return;
  // The error thrown here is reported: reset the thread's last error, which
  // the runtime also set, so that the next launch's check does not report it
  // again (an error that corrupts the context stays, as CUDA keeps it).
  cudaGetLastError();
  throw std::runtime_error(std::string(where.file_name()) + ":" + std::to_string(where.line()) +
                           ": " + call + " failed: " + cudaGetErrorName(error) + ": " +
                           cudaGetErrorString(error));
}

}  // namespace overlap::finders

#define CUDA_CHECK(call) \
  ::overlap::finders::checkCuda((call), #call, std::source_location::current())
