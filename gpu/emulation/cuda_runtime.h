// The CUDA emulation's <cuda_runtime.h>: the slice of the CUDA runtime API
// and of the device language that gpu/cuda/*.cu use, for the host compiler.  In
// the emulation build (OVERLAP_CUDA_EMULATION) this directory is on the
// include path ahead of the toolkit, so the .cu files compile unchanged; the
// build rewrites `kernel<<<grid, block, shared, stream>>>(args)` into a call
// of cuda_emulation::launchKernel (gpu/emulation/rewrite_launches.py).
//
// What the emulation holds to, so that a bug a GPU would show shows here:
// - Every CUDA thread is a fiber with its own code path; a warp collective
//   returns only when every lane its mask names has reached it, and
//   __syncthreads when the whole block has.  A lane that exits or waits at a
//   different collective aborts the program naming block, thread and mask.
// - Streams are lazy: enqueued work runs when the host waits for it (event or
//   stream or device synchronize, a blocking copy, cudaFree), never before.
// - Device and pinned allocations start as garbage (0xA5 bytes); copies,
//   memsets, frees and a kernel's pointer arguments are checked against the
//   live allocations, and a violation aborts naming the call site.
// - Launch limits give cudaErrorInvalidConfiguration through cudaGetLastError,
//   and a launch that cannot map one block's thread stacks (their local
//   memory; the address space full) cudaErrorMemoryAllocation, as a GPU that
//   cannot allocate a launch's local memory; either launches nothing.  With
//   room for fewer, the grid runs whole on fewer OS threads.
// - The emulation's own memory running out while it runs a grid makes the
//   call that waited for it return cudaErrorMemoryAllocation; no call throws
//   (cudaFree is called from destructors).
// - Stream capture records what is enqueued on the capturing stream (copies,
//   memsets, launches, external event records) as a graph; a launched graph
//   enqueues it all again, checking its pointers anew.  While a thread
//   captures, what would not be legal on a GPU fails with
//   cudaErrorStreamCaptureUnsupported and spoils the capture: waiting on the
//   capturing stream, allocating or freeing, a plain event record on it (the
//   emulation records only external ones into a graph).
// What it cannot show: timing, memory ordering and races between threads
// (a block's threads run one at a time on one OS thread), the real driver.
#pragma once

#include <cstddef>
#include <cstdint>
#include <source_location>

// Device-language keywords: plain C++ on the host.
#define __global__
#define __device__
#define __host__
#define __forceinline__ inline
#define __launch_bounds__(...)
// A block runs start to finish on one OS thread (executor.cpp), so a
// thread_local is per block.  (No __noinline__: libstdc++ spells its own
// attribute that way.)
#define __shared__ static thread_local

using cudaEvent_t = struct CudaEmulationEvent*;
using cudaStream_t = struct CudaEmulationStream*;
using cudaGraph_t = struct CudaEmulationGraph*;
using cudaGraphExec_t = struct CudaEmulationGraphExec*;

// The values of the toolkit's driver_types.h, so codes compare as on a GPU.
enum cudaError_t {
  cudaSuccess = 0,
  cudaErrorInvalidValue = 1,
  cudaErrorMemoryAllocation = 2,
  cudaErrorInvalidConfiguration = 9,
  cudaErrorInvalidDevicePointer = 17,
  cudaErrorNoDevice = 100,
  cudaErrorInvalidDevice = 101,
  cudaErrorInvalidResourceHandle = 400,
  cudaErrorNotReady = 600,
  cudaErrorStreamCaptureUnsupported = 900,
  cudaErrorStreamCaptureInvalidated = 901,
  cudaErrorStreamCaptureWrongThread = 908,
};
using cudaError = cudaError_t;

enum cudaMemcpyKind {
  cudaMemcpyHostToHost = 0,
  cudaMemcpyHostToDevice = 1,
  cudaMemcpyDeviceToHost = 2,
  cudaMemcpyDeviceToDevice = 3,
  cudaMemcpyDefault = 4,
};

inline constexpr unsigned cudaStreamDefault = 0x00;
inline constexpr unsigned cudaStreamNonBlocking = 0x01;
inline constexpr unsigned cudaEventDefault = 0x00;
inline constexpr unsigned cudaEventBlockingSync = 0x01;
inline constexpr unsigned cudaEventDisableTiming = 0x02;
inline constexpr unsigned cudaEventRecordDefault = 0x00;
inline constexpr unsigned cudaEventRecordExternal = 0x01;

enum cudaStreamCaptureMode {
  cudaStreamCaptureModeGlobal = 0,
  cudaStreamCaptureModeThreadLocal = 1,
  cudaStreamCaptureModeRelaxed = 2,
};

struct uint3 {
  unsigned x, y, z;
};

struct dim3 {
  unsigned x = 1, y = 1, z = 1;
  constexpr dim3(unsigned vx = 1, unsigned vy = 1, unsigned vz = 1) : x(vx), y(vy), z(vz) {}
  constexpr dim3(uint3 v) : x(v.x), y(v.y), z(v.z) {}
};

struct cudaDeviceProp {
  char name[256];
  std::size_t totalGlobalMem;
  std::size_t sharedMemPerBlock;
  int warpSize;
  int maxThreadsPerBlock;
  int maxThreadsDim[3];
  int maxGridSize[3];
  int major;
  int minor;
  int multiProcessorCount;
};

struct cudaFuncAttributes {
  std::size_t sharedSizeBytes;
  int maxThreadsPerBlock;
  int numRegs;
  int ptxVersion;
  int binaryVersion;
};

using CudaSite = std::source_location;
#define OVERLAP_CUDA_SITE CudaSite site = CudaSite::current()

// The runtime API (gpu/emulation/runtime.cpp).  Each call takes its call site
// as a defaulted last argument, for the messages of the memory checks.
cudaError_t cudaGetDeviceCount(int* count);
cudaError_t cudaGetDevice(int* device);
cudaError_t cudaSetDevice(int device);
cudaError_t cudaGetDeviceProperties(cudaDeviceProp* properties, int device);
cudaError_t cudaDeviceSynchronize(OVERLAP_CUDA_SITE);
cudaError_t cudaGetLastError();
cudaError_t cudaPeekAtLastError();
const char* cudaGetErrorName(cudaError_t error);
const char* cudaGetErrorString(cudaError_t error);

cudaError_t cudaMalloc(void** pointer, std::size_t bytes, OVERLAP_CUDA_SITE);
cudaError_t cudaMallocHost(void** pointer, std::size_t bytes, OVERLAP_CUDA_SITE);
cudaError_t cudaFree(void* pointer, OVERLAP_CUDA_SITE);
cudaError_t cudaFreeHost(void* pointer, OVERLAP_CUDA_SITE);
cudaError_t cudaMemcpy(void* to, const void* from, std::size_t bytes, cudaMemcpyKind kind,
                       OVERLAP_CUDA_SITE);
cudaError_t cudaMemcpyAsync(void* to, const void* from, std::size_t bytes, cudaMemcpyKind kind,
                            cudaStream_t stream = nullptr, OVERLAP_CUDA_SITE);
cudaError_t cudaMemset(void* to, int value, std::size_t bytes, OVERLAP_CUDA_SITE);
cudaError_t cudaMemsetAsync(void* to, int value, std::size_t bytes, cudaStream_t stream = nullptr,
                            OVERLAP_CUDA_SITE);

cudaError_t cudaStreamCreate(cudaStream_t* stream);
cudaError_t cudaStreamCreateWithFlags(cudaStream_t* stream, unsigned flags);
cudaError_t cudaStreamDestroy(cudaStream_t stream);
cudaError_t cudaStreamSynchronize(cudaStream_t stream, OVERLAP_CUDA_SITE);
cudaError_t cudaStreamQuery(cudaStream_t stream, OVERLAP_CUDA_SITE);
cudaError_t cudaStreamWaitEvent(cudaStream_t stream, cudaEvent_t event, unsigned flags = 0);
// Runs fn(user_data) on the host in the stream's order, when the stream is
// waited for (the emulation's CUB stand-ins run their work this way).
using cudaHostFn_t = void (*)(void* user_data);
cudaError_t cudaLaunchHostFunc(cudaStream_t stream, cudaHostFn_t fn, void* user_data);

cudaError_t cudaEventCreate(cudaEvent_t* event);
cudaError_t cudaEventCreateWithFlags(cudaEvent_t* event, unsigned flags);
cudaError_t cudaEventDestroy(cudaEvent_t event);
cudaError_t cudaEventRecord(cudaEvent_t event, cudaStream_t stream = nullptr);
// cudaEventRecordExternal: while `stream` captures, the record becomes a node
// of the graph (and is made each time the graph is launched).
cudaError_t cudaEventRecordWithFlags(cudaEvent_t event, cudaStream_t stream = nullptr,
                                     unsigned flags = cudaEventRecordDefault);
cudaError_t cudaEventSynchronize(cudaEvent_t event, OVERLAP_CUDA_SITE);
cudaError_t cudaEventQuery(cudaEvent_t event, OVERLAP_CUDA_SITE);
cudaError_t cudaEventElapsedTime(float* ms, cudaEvent_t start, cudaEvent_t end);

// Graphs, by stream capture only.  The emulation captures on the calling
// thread alone, whatever the mode.
cudaError_t cudaStreamBeginCapture(cudaStream_t stream, cudaStreamCaptureMode mode);
cudaError_t cudaStreamEndCapture(cudaStream_t stream, cudaGraph_t* graph);
cudaError_t cudaGraphInstantiate(cudaGraphExec_t* exec, cudaGraph_t graph,
                                 unsigned long long flags = 0);
cudaError_t cudaGraphLaunch(cudaGraphExec_t exec, cudaStream_t stream);
cudaError_t cudaGraphExecDestroy(cudaGraphExec_t exec);
cudaError_t cudaGraphDestroy(cudaGraph_t graph);

// Every kernel is an ordinary function here; its attributes are the device's.
template <class... Params>
cudaError_t cudaFuncGetAttributes(cudaFuncAttributes* attributes, void (*kernel)(Params...)) {
  if (attributes == nullptr || kernel == nullptr) return cudaErrorInvalidValue;
  *attributes = cudaFuncAttributes{0, 1024, 0, 0, 0};
  return cudaSuccess;
}

#undef OVERLAP_CUDA_SITE

#include "gpu/emulation/device_functions.h"
#include "gpu/emulation/kernel_launch.h"
