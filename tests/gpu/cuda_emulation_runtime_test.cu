// The CUDA emulation's runtime (gpu/emulation/runtime.cpp): lazy streams and
// their order, events, garbage-filled and checked memory, and launch limits
// with the error codes of a real device, and graphs by stream capture.
// Emulation build only.
#include <cuda_runtime.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <vector>

#include "gpu/emulation/api_counters.h"

namespace {

constexpr unsigned char kGarbage = 0xA5;

class CudaEmulationRuntimeDeathTest : public ::testing::Test {
 protected:
  void SetUp() override { GTEST_FLAG_SET(death_test_style, "threadsafe"); }
};

__global__ void addOne(int* values, int count) {
  const int i = static_cast<int>(blockIdx.x * blockDim.x + threadIdx.x);
  if (i < count) values[i] += 1;
}

__global__ void setFlag(int* flag) {
  *flag = 1;
}

bool allGarbage(const void* memory, std::size_t bytes) {
  const auto* begin = static_cast<const unsigned char*>(memory);
  for (std::size_t i = 0; i < bytes; ++i) {
    if (begin[i] != kGarbage) return false;
  }
  return true;
}

// --- memory starts as garbage ------------------------------------------------

TEST(CudaEmulationRuntime, DeviceAndPinnedMemoryStartAsGarbage) {
  void* device = nullptr;
  void* pinned = nullptr;
  ASSERT_EQ(cudaMalloc(&device, 1000), cudaSuccess);
  ASSERT_EQ(cudaMallocHost(&pinned, 1000), cudaSuccess);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(device) % 256, 0u);
  EXPECT_TRUE(allGarbage(pinned, 1000));
  ASSERT_EQ(cudaMemcpy(pinned, device, 1000, cudaMemcpyDeviceToHost), cudaSuccess);
  EXPECT_TRUE(allGarbage(pinned, 1000));
  cudaFree(device);
  cudaFreeHost(pinned);
}

// The process's mapped address space, in bytes (/proc/self/statm's first field).
std::size_t mappedBytes() {
  std::ifstream statm("/proc/self/statm");
  std::size_t pages = 0;
  statm >> pages;
  return pages * static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
}

// --- a launch without room for its fibers' stacks ----------------------------

TEST_F(CudaEmulationRuntimeDeathTest, ALaunchWithNoRoomForItsStacksIsOutOfMemoryAndRunsNothing) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer maps its own memory under the limit";
#endif
  EXPECT_EXIT(
      {
        int* flag = nullptr;
        cudaMalloc(reinterpret_cast<void**>(&flag), sizeof(int));
        cudaMemset(flag, 0, sizeof(int));
        int host = -1;
        cudaMemcpy(&host, flag, sizeof(int), cudaMemcpyDeviceToHost);
        // The address space as it is and 8 MiB: a 1024-thread block's
        // stacks take 64 KiB a thread.
        rlimit limit{};
        getrlimit(RLIMIT_AS, &limit);
        const rlimit before = limit;
        limit.rlim_cur = mappedBytes() + (8u << 20);
        setrlimit(RLIMIT_AS, &limit);
        setFlag<<<1, 1024>>>(flag);
        const cudaError_t refused = cudaGetLastError();
        cudaMemcpy(&host, flag, sizeof(int), cudaMemcpyDeviceToHost);
        const int ran_refused = host;
        // With the room back the same launch runs.
        setrlimit(RLIMIT_AS, &before);
        setFlag<<<1, 1024>>>(flag);
        const cudaError_t launched = cudaGetLastError();
        cudaMemcpy(&host, flag, sizeof(int), cudaMemcpyDeviceToHost);
        std::fprintf(stderr, "%s ran %d; then %s ran %d\n", cudaGetErrorName(refused), ran_refused,
                     cudaGetErrorName(launched), host);
        std::exit(0);
      },
      ::testing::ExitedWithCode(0), "cudaErrorMemoryAllocation ran 0; then cudaSuccess ran 1");
}

TEST_F(CudaEmulationRuntimeDeathTest, AGridWithRoomForFewerThreadsRunsWholeOnTheThreadsItHas) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer maps its own memory under the limit";
#endif
  EXPECT_EXIT(
      {
        // 256 OS threads of 1024 fibers each would map 16 GiB of stacks.
        setenv("OVERLAP_CUDA_EMULATION_THREADS", "256", 1);
        constexpr int kCount = 256 * 1024;
        int* values = nullptr;
        cudaMalloc(reinterpret_cast<void**>(&values), kCount * sizeof(int));
        cudaMemset(values, 0, kCount * sizeof(int));
        rlimit limit{};
        getrlimit(RLIMIT_AS, &limit);
        limit.rlim_cur = mappedBytes() + (256u << 20);  // room for a few runners' stacks
        setrlimit(RLIMIT_AS, &limit);
        addOne<<<256, 1024>>>(values, kCount);
        const cudaError_t launched = cudaGetLastError();
        std::vector<int> host(kCount, -1);
        const cudaError_t copied =
            cudaMemcpy(host.data(), values, kCount * sizeof(int), cudaMemcpyDeviceToHost);
        int ones = 0;
        for (const int value : host) ones += value == 1 ? 1 : 0;
        std::fprintf(stderr, "%s %s %d of %d\n", cudaGetErrorName(launched),
                     cudaGetErrorName(copied), ones, kCount);
        std::exit(0);
      },
      ::testing::ExitedWithCode(0), "cudaSuccess cudaSuccess 262144 of 262144");
}

// --- lazy streams --------------------------------------------------------------

TEST(CudaEmulationRuntime, StreamWorkRunsOnlyWhenWaitedFor) {
  cudaStream_t stream = nullptr;
  ASSERT_EQ(cudaStreamCreateWithFlags(&stream, cudaStreamNonBlocking), cudaSuccess);
  int* device = nullptr;
  int* pinned = nullptr;
  cudaMalloc(reinterpret_cast<void**>(&device), sizeof(int));
  cudaMallocHost(reinterpret_cast<void**>(&pinned), sizeof(int));
  cudaEvent_t done = nullptr;
  cudaEventCreate(&done);
  cudaMemsetAsync(device, 0, sizeof(int), stream);
  setFlag<<<1, 1, 0, stream>>>(device);
  cudaMemcpyAsync(pinned, device, sizeof(int), cudaMemcpyDeviceToHost, stream);
  cudaEventRecord(done, stream);
  // A host that reads now, without waiting, reads what was there: garbage.
  EXPECT_TRUE(allGarbage(pinned, sizeof(int)));
  ASSERT_EQ(cudaEventSynchronize(done), cudaSuccess);
  EXPECT_EQ(*pinned, 1);
  cudaEventDestroy(done);
  cudaFree(device);
  cudaFreeHost(pinned);
  cudaStreamDestroy(stream);
}

TEST(CudaEmulationRuntime, AStreamRunsInOrderAndWaitsForAnotherStreamsEvent) {
  cudaStream_t first = nullptr;
  cudaStream_t second = nullptr;
  cudaStreamCreateWithFlags(&first, cudaStreamNonBlocking);
  cudaStreamCreateWithFlags(&second, cudaStreamNonBlocking);
  cudaEvent_t written = nullptr;
  cudaEventCreate(&written);
  constexpr int kCount = 300;
  int* values = nullptr;
  cudaMalloc(reinterpret_cast<void**>(&values), kCount * sizeof(int));
  std::vector<int> host(kCount, 7);
  cudaMemcpyAsync(values, host.data(), kCount * sizeof(int), cudaMemcpyHostToDevice, first);
  addOne<<<3, 128, 0, first>>>(values, kCount);
  cudaEventRecord(written, first);
  cudaStreamWaitEvent(second, written);
  addOne<<<3, 128, 0, second>>>(values, kCount);
  std::vector<int> result(kCount);
  cudaMemcpyAsync(result.data(), values, kCount * sizeof(int), cudaMemcpyDeviceToHost, second);
  // Waiting for `second` alone runs `first` up to the event, then `second`.
  ASSERT_EQ(cudaStreamSynchronize(second), cudaSuccess);
  EXPECT_EQ(result, std::vector<int>(kCount, 9));
  cudaFree(values);
  cudaEventDestroy(written);
  cudaStreamDestroy(first);
  cudaStreamDestroy(second);
}

TEST(CudaEmulationRuntime, ABlockingCopyWaitsForTheLegacyStreamsKernel) {
  int* flag = nullptr;
  cudaMalloc(reinterpret_cast<void**>(&flag), sizeof(int));
  cudaMemset(flag, 0, sizeof(int));
  setFlag<<<1, 1>>>(flag);
  int host = 0;
  ASSERT_EQ(cudaMemcpy(&host, flag, sizeof(int), cudaMemcpyDeviceToHost), cudaSuccess);
  EXPECT_EQ(host, 1);
  cudaFree(flag);
}

TEST(CudaEmulationRuntime, EventsTimeWhatRanBetweenThem) {
  cudaEvent_t start = nullptr;
  cudaEvent_t end = nullptr;
  cudaEvent_t never = nullptr;
  cudaEventCreate(&start);
  cudaEventCreate(&end);
  cudaEventCreate(&never);
  int* values = nullptr;
  cudaMalloc(reinterpret_cast<void**>(&values), 4096 * sizeof(int));
  cudaEventRecord(start);
  addOne<<<16, 256>>>(values, 4096);
  cudaEventRecord(end);
  float ms = -1;
  // Not run yet: the events have no timestamps.
  EXPECT_EQ(cudaEventElapsedTime(&ms, start, end), cudaErrorNotReady);
  ASSERT_EQ(cudaEventSynchronize(end), cudaSuccess);
  ASSERT_EQ(cudaEventElapsedTime(&ms, start, end), cudaSuccess);
  EXPECT_GE(ms, 0.0f);
  EXPECT_EQ(cudaEventElapsedTime(&ms, start, never), cudaErrorInvalidResourceHandle);
  cudaGetLastError();
  cudaFree(values);
  for (cudaEvent_t event : {start, end, never}) cudaEventDestroy(event);
}

// --- launch limits -------------------------------------------------------------

TEST(CudaEmulationRuntime, LaunchLimitsGiveTheDevicesErrorAndLaunchNothing) {
  int* flag = nullptr;
  cudaMalloc(reinterpret_cast<void**>(&flag), sizeof(int));
  cudaMemset(flag, 0, sizeof(int));
  ASSERT_EQ(cudaGetLastError(), cudaSuccess);
  struct Case {
    dim3 grid;
    dim3 block;
    std::size_t shared_bytes;
  };
  const Case bad[] = {
      {1, 1025, 0},                // threads per block
      {1, dim3(32, 32, 2), 0},     // their product
      {1, dim3(1, 1, 65), 0},      // block z
      {dim3(1, 65536), 32, 0},     // grid y
      {dim3(1, 1, 65536), 32, 0},  // grid z
      {0, 32, 0},                  // an empty grid
      {1, dim3(32, 0), 0},         // an empty block
      {1, 32, 48 * 1024 + 1},      // shared memory per block
  };
  for (const Case& launch : bad) {
    setFlag<<<launch.grid, launch.block, launch.shared_bytes>>>(flag);
    EXPECT_EQ(cudaPeekAtLastError(), cudaErrorInvalidConfiguration);
    EXPECT_EQ(cudaGetLastError(), cudaErrorInvalidConfiguration);
    EXPECT_EQ(cudaGetLastError(), cudaSuccess) << "cudaGetLastError clears the error";
  }
  int host = -1;
  cudaMemcpy(&host, flag, sizeof(int), cudaMemcpyDeviceToHost);
  EXPECT_EQ(host, 0) << "a rejected launch must not run";
  setFlag<<<1, dim3(32, 32, 1), 48 * 1024>>>(flag);  // every limit at its largest
  EXPECT_EQ(cudaGetLastError(), cudaSuccess);
  cudaMemcpy(&host, flag, sizeof(int), cudaMemcpyDeviceToHost);
  EXPECT_EQ(host, 1);
  cudaFree(flag);
}

// --- memory checks -------------------------------------------------------------

TEST_F(CudaEmulationRuntimeDeathTest, ACopyPastTheEndOfAnAllocationAbortsWithItsCallSite) {
  void* device = nullptr;
  cudaMalloc(&device, 100);
  std::vector<char> host(200);
  EXPECT_DEATH(cudaMemcpy(device, host.data(), 101, cudaMemcpyHostToDevice),
               "cudaMemcpy at .*cuda_emulation_runtime_test.cu:[0-9]+: the destination range of "
               "101 bytes at offset 0 runs past the end of a device allocation of 100 bytes made "
               "at .*cuda_emulation_runtime_test.cu:[0-9]+");
  EXPECT_DEATH(cudaMemsetAsync(static_cast<char*>(device) + 50, 0, 51),
               "cudaMemsetAsync at .*: the destination range of 51 bytes at offset 50 runs past");
  cudaFree(device);
}

TEST_F(CudaEmulationRuntimeDeathTest, HostMemoryWhereTheCopySaysDeviceAborts) {
  std::vector<char> host(64);
  std::vector<char> other(64);
  EXPECT_DEATH(cudaMemcpy(host.data(), other.data(), 64, cudaMemcpyHostToDevice),
               "cudaMemcpy at .*cuda_emulation_runtime_test.cu:[0-9]+: the destination 0x[0-9a-f]+ "
               "is not in a live device allocation");
}

TEST_F(CudaEmulationRuntimeDeathTest, FreeingWhatIsNotALiveAllocationAborts) {
  void* device = nullptr;
  cudaMalloc(&device, 64);
  cudaFree(device);
  EXPECT_DEATH(cudaFree(device),
               "cudaFree at .*cuda_emulation_runtime_test.cu:[0-9]+: "
               "0x[0-9a-f]+ is not a live device allocation");
  void* pinned = nullptr;
  cudaMallocHost(&pinned, 64);
  EXPECT_DEATH(cudaFree(pinned), "is not a live device allocation");
  cudaFreeHost(pinned);
}

TEST_F(CudaEmulationRuntimeDeathTest, AKernelGivenAHostPointerAborts) {
  int on_the_stack = 0;
  EXPECT_DEATH(addOne<<<1, 32>>>(&on_the_stack, 1),
               "kernel addOne launched at .*cuda_emulation_runtime_test.cu:[0-9]+: pointer "
               "argument 1 \\(0x[0-9a-f]+\\) is not in a live device or pinned allocation");
}

#if defined(__SANITIZE_ADDRESS__)
__global__ void writePastTheEnd(int* values, int count) {
  values[count + static_cast<int>(threadIdx.x)] = 1;
}

// Inside a kernel only AddressSanitizer sees an access (device memory is host
// memory with ASan's red zones here): the CI's ASan build is the emulation's
// memcheck, naming the kernel and its line.  (Built in ASan builds only.)
TEST_F(CudaEmulationRuntimeDeathTest, AnOutOfBoundsWriteInAKernelIsCaughtUnderAsan) {
  int* values = nullptr;
  cudaMalloc(reinterpret_cast<void**>(&values), 64 * sizeof(int));
  EXPECT_DEATH(
      {
        writePastTheEnd<<<1, 1>>>(values, 64);
        cudaDeviceSynchronize();
      },
      "heap-buffer-overflow.*WRITE of size 4.*writePastTheEnd");
  cudaFree(values);
}
#endif

// --- graphs by stream capture --------------------------------------------------

namespace graphs {

// A stream with an upload, a kernel, an external event record and a copy back
// captured as a graph, then launched on it twice.
struct CapturedChain {
  cudaStream_t stream = nullptr;
  cudaEvent_t done = nullptr;
  int* device = nullptr;
  int* host = nullptr;
  cudaGraphExec_t exec = nullptr;

  CapturedChain() {
    cudaStreamCreateWithFlags(&stream, cudaStreamNonBlocking);
    cudaEventCreate(&done);
    cudaMalloc(reinterpret_cast<void**>(&device), 64 * sizeof(int));
    cudaMallocHost(reinterpret_cast<void**>(&host), 64 * sizeof(int));
    for (int i = 0; i < 64; ++i) host[i] = i;
  }
  ~CapturedChain() {
    if (exec != nullptr) cudaGraphExecDestroy(exec);
    cudaFreeHost(host);
    cudaFree(device);
    cudaEventDestroy(done);
    cudaStreamDestroy(stream);
  }

  cudaError_t capture() {
    EXPECT_EQ(cudaStreamBeginCapture(stream, cudaStreamCaptureModeThreadLocal), cudaSuccess);
    cudaMemcpyAsync(device, host, 64 * sizeof(int), cudaMemcpyHostToDevice, stream);
    addOne<<<1, 64, 0, stream>>>(device, 64);
    cudaMemcpyAsync(host, device, 64 * sizeof(int), cudaMemcpyDeviceToHost, stream);
    cudaEventRecordWithFlags(done, stream, cudaEventRecordExternal);
    cudaGraph_t graph = nullptr;
    const cudaError_t ended = cudaStreamEndCapture(stream, &graph);
    if (ended != cudaSuccess) return ended;
    EXPECT_EQ(cudaGraphInstantiate(&exec, graph, 0), cudaSuccess);
    EXPECT_EQ(cudaGraphDestroy(graph), cudaSuccess);  // the instance keeps its nodes
    return cudaSuccess;
  }
};

}  // namespace graphs

TEST(CudaEmulationRuntime, ACapturedGraphRunsNothingUntilLaunchedThenRunsOnEachLaunch) {
  graphs::CapturedChain chain;
  ASSERT_EQ(chain.capture(), cudaSuccess);
  ASSERT_EQ(cudaStreamSynchronize(chain.stream), cudaSuccess);
  EXPECT_EQ(chain.host[5], 5) << "capturing ran the work";
  for (int launch = 1; launch <= 2; ++launch) {
    const overlap::cuda_emulation::ApiCounters before = overlap::cuda_emulation::apiCounters();
    ASSERT_EQ(cudaGraphLaunch(chain.exec, chain.stream), cudaSuccess);
    ASSERT_EQ(cudaEventSynchronize(chain.done), cudaSuccess);
    const overlap::cuda_emulation::ApiCounters counted =
        overlap::cuda_emulation::apiCounters() - before;
    EXPECT_EQ(chain.host[5], 5 + launch);
    // One call launches the graph, one waits; the nodes' work is counted as done.
    EXPECT_EQ(counted.api_calls, 2u);
    EXPECT_EQ(counted.kernel_launches, 1u);
    EXPECT_EQ(counted.copies_to_device, 1u);
    EXPECT_EQ(counted.copies_to_host, 1u);
    EXPECT_EQ(counted.bytes_to_host, 64 * sizeof(int));
    EXPECT_EQ(counted.event_records, 1u);
  }
}

TEST(CudaEmulationRuntime, WaitingOrAllocatingWhileCapturingSpoilsTheCapture) {
  graphs::CapturedChain chain;
  ASSERT_EQ(cudaStreamBeginCapture(chain.stream, cudaStreamCaptureModeThreadLocal), cudaSuccess);
  EXPECT_EQ(cudaStreamSynchronize(chain.stream), cudaErrorStreamCaptureUnsupported);
  cudaGraph_t graph = nullptr;
  EXPECT_EQ(cudaStreamEndCapture(chain.stream, &graph), cudaErrorStreamCaptureInvalidated);
  EXPECT_EQ(graph, nullptr);

  ASSERT_EQ(cudaStreamBeginCapture(chain.stream, cudaStreamCaptureModeThreadLocal), cudaSuccess);
  void* memory = nullptr;
  EXPECT_EQ(cudaMalloc(&memory, 16), cudaErrorStreamCaptureUnsupported);
  EXPECT_EQ(cudaEventRecord(chain.done, chain.stream), cudaErrorStreamCaptureUnsupported);
  EXPECT_EQ(cudaStreamEndCapture(chain.stream, &graph), cudaErrorStreamCaptureInvalidated);
  cudaGetLastError();
  // The stream works as before once the capture ended.
  ASSERT_EQ(chain.capture(), cudaSuccess);
  ASSERT_EQ(cudaGraphLaunch(chain.exec, chain.stream), cudaSuccess);
  ASSERT_EQ(cudaStreamSynchronize(chain.stream), cudaSuccess);
  EXPECT_EQ(chain.host[0], 1);
}

TEST_F(CudaEmulationRuntimeDeathTest, AGraphLaunchChecksItsPointersAgain) {
  EXPECT_DEATH(
      {
        graphs::CapturedChain chain;
        chain.capture();
        cudaFree(chain.device);
        cudaGraphLaunch(chain.exec, chain.stream);
      },
      "not in a live device");
}

}  // namespace
