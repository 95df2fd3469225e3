// The CUDA emulation's own tests (gpu/emulation/): one small kernel per rule
// the emulation holds to, and per violation it must catch, each caught with
// a message naming what went wrong and where.  Built only in the emulation
// build (OVERLAP_CUDA_EMULATION), through the same launch rewrite as gpu/cuda/*.cu.
#include <cuda_runtime.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <numeric>
#include <string>
#include <vector>

#include "gpu/pair_finder.h"

namespace {

constexpr unsigned kFullWarp = 0xFFFFFFFFu;

template <class T>
class Device {
 public:
  explicit Device(std::size_t count) : count_(count) {
    EXPECT_EQ(cudaMalloc(reinterpret_cast<void**>(&data_), count * sizeof(T)), cudaSuccess);
  }
  ~Device() { cudaFree(data_); }
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;
  T* get() const { return data_; }
  std::vector<T> copyOut() const {
    std::vector<T> host(count_);
    EXPECT_EQ(cudaMemcpy(host.data(), data_, count_ * sizeof(T), cudaMemcpyDeviceToHost),
              cudaSuccess);
    return host;
  }

 private:
  T* data_ = nullptr;
  std::size_t count_;
};

class CudaEmulationDeathTest : public ::testing::Test {
 protected:
  // The emulation runs blocks on worker threads: fork-only death tests are unsafe.
  void SetUp() override { GTEST_FLAG_SET(death_test_style, "threadsafe"); }
};

// --- the device and its threads ----------------------------------------------

TEST(CudaEmulation, OneDeviceNamedForWhatItIs) {
  int count = 0;
  ASSERT_EQ(cudaGetDeviceCount(&count), cudaSuccess);
  EXPECT_EQ(count, 1);
  std::string why;
  EXPECT_TRUE(overlap::finders::cudaDeviceAvailable(&why)) << why;
  EXPECT_TRUE(overlap::finders::cudaDeviceName().starts_with("CUDA emulation on the CPU, "))
      << overlap::finders::cudaDeviceName();
}

__global__ void writeCoordinates(unsigned* out) {
  const unsigned block = (blockIdx.z * gridDim.y + blockIdx.y) * gridDim.x + blockIdx.x;
  const unsigned thread = (threadIdx.z * blockDim.y + threadIdx.y) * blockDim.x + threadIdx.x;
  const unsigned threads = blockDim.x * blockDim.y * blockDim.z;
  out[block * threads + thread] += block * threads + thread + 1;
}

TEST(CudaEmulation, EveryThreadOfAThreeDimensionalGridRunsOnceWithItsCoordinates) {
  const dim3 grid(3, 2, 2);
  const dim3 block(4, 3, 5);
  const std::size_t total = 12 * 60;
  Device<unsigned> out(total);
  ASSERT_EQ(cudaMemset(out.get(), 0, total * sizeof(unsigned)), cudaSuccess);
  writeCoordinates<<<grid, block>>>(out.get());
  ASSERT_EQ(cudaGetLastError(), cudaSuccess);
  const std::vector<unsigned> host = out.copyOut();
  for (std::size_t i = 0; i < total; ++i) ASSERT_EQ(host[i], i + 1) << i;
}

// Each thread takes its own path: odd threads loop longer than even ones, and
// a ballot after the branches still sees every lane.
__global__ void divergentPaths(unsigned* out, unsigned* ballots) {
  const unsigned t = threadIdx.x;
  unsigned value = 0;
  if (t % 2 == 1) {
    for (unsigned i = 0; i <= t; ++i) value += i;
  } else {
    value = t * 100;
  }
  out[t] = value;
  const unsigned ballot = __ballot_sync(kFullWarp, t % 2 == 1);
  if (t % 32 == 0) ballots[t / 32] = ballot;
}

TEST(CudaEmulation, ThreadsFollowTheirOwnPathsAndMeetAtTheBallot) {
  Device<unsigned> out(64);
  Device<unsigned> ballots(2);
  divergentPaths<<<1, 64>>>(out.get(), ballots.get());
  const std::vector<unsigned> host = out.copyOut();
  for (unsigned t = 0; t < 64; ++t) EXPECT_EQ(host[t], t % 2 == 1 ? t * (t + 1) / 2 : t * 100);
  EXPECT_EQ(ballots.copyOut(), (std::vector<unsigned>{0xAAAAAAAAu, 0xAAAAAAAAu}));
}

__global__ void shuffles(int* out) {
  const int lane = static_cast<int>(threadIdx.x);
  int* row = out + 6 * lane;
  row[0] = __shfl_sync(kFullWarp, lane * 10, 3);
  row[1] = __shfl_up_sync(kFullWarp, lane, 2);
  row[2] = __shfl_down_sync(kFullWarp, lane, 5, 16);
  row[3] = __shfl_xor_sync(kFullWarp, lane, 1);
  row[4] = __any_sync(kFullWarp, lane == 17);
  row[5] = __all_sync(kFullWarp, lane < 31);
}

TEST(CudaEmulation, ShufflesFollowCudasLaneRules) {
  Device<int> out(32 * 6);
  shuffles<<<1, 32>>>(out.get());
  const std::vector<int> host = out.copyOut();
  for (int lane = 0; lane < 32; ++lane) {
    const int* row = host.data() + 6 * lane;
    EXPECT_EQ(row[0], 30);
    EXPECT_EQ(row[1], lane < 2 ? lane : lane - 2);
    EXPECT_EQ(row[2], lane % 16 + 5 < 16 ? lane + 5 : lane);  // stays in its 16-lane segment
    EXPECT_EQ(row[3], lane ^ 1);
    EXPECT_EQ(row[4], 1);
    EXPECT_EQ(row[5], 0);
  }
}

// The two half-warps meet separately: a mask names only the lanes it waits for.
__global__ void halfWarps(unsigned* out) {
  const unsigned lane = threadIdx.x;
  const unsigned mask = lane < 16 ? 0x0000FFFFu : 0xFFFF0000u;
  __syncwarp(mask);
  out[lane] = __ballot_sync(mask, lane % 4 == 0);
}

TEST(CudaEmulation, PartialMasksMeetOnlyTheirLanes) {
  Device<unsigned> out(32);
  halfWarps<<<1, 32>>>(out.get());
  const std::vector<unsigned> host = out.copyOut();
  for (unsigned lane = 0; lane < 32; ++lane) {
    EXPECT_EQ(host[lane], lane < 16 ? 0x00001111u : 0x11110000u) << lane;
  }
}

// A block-wide sum through shared memory, with or without the barrier.
template <bool kBarrier>
__global__ void blockSum(unsigned* out) {
  __shared__ unsigned values[256];
  values[threadIdx.x] = threadIdx.x + 1;
  if (kBarrier) __syncthreads();
  if (threadIdx.x == 0) {
    unsigned sum = 0;
    for (unsigned i = 0; i < blockDim.x; ++i) sum += values[i];
    out[blockIdx.x] = sum;
  }
  if (kBarrier) __syncthreads();  // nobody overwrites values before thread 0 read them
}

TEST(CudaEmulation, SyncthreadsOrdersTheBlockAndItsAbsenceShows) {
  Device<unsigned> out(8);
  blockSum<true><<<8, 256>>>(out.get());
  EXPECT_EQ(out.copyOut(), std::vector<unsigned>(8, 256 * 257 / 2));
  // Without the barrier thread 0 runs to its end before the others write.
  blockSum<false><<<1, 256>>>(out.get());
  EXPECT_NE(out.copyOut()[0], 256u * 257 / 2);
}

__global__ void atomics(unsigned* counter32, unsigned long long* counter64, float* sum,
                        int* popcounts, unsigned* extremes) {
  atomicAdd(counter32, 1u);
  atomicAdd(counter64, 1ull << 33);
  atomicAdd(sum, 0.5f);
  const unsigned i = blockIdx.x * blockDim.x + threadIdx.x;
  popcounts[i] = __popc(i) + __popcll(static_cast<unsigned long long>(i) << 40);
  atomicMax(&extremes[0], i);
  atomicMin(&extremes[1], i);
}

TEST(CudaEmulation, AtomicsFromEveryBlockAddUpAndPopcCounts) {
  constexpr unsigned kBlocks = 64;
  constexpr unsigned kThreads = 128;
  Device<unsigned> counter32(1);
  Device<unsigned long long> counter64(1);
  Device<float> sum(1);
  Device<int> popcounts(kBlocks * kThreads);
  Device<unsigned> extremes(2);
  const unsigned start[2] = {0, ~0u};
  cudaMemcpy(extremes.get(), start, sizeof start, cudaMemcpyHostToDevice);
  cudaMemset(counter32.get(), 0, sizeof(unsigned));
  cudaMemset(counter64.get(), 0, sizeof(unsigned long long));
  cudaMemset(sum.get(), 0, sizeof(float));
  atomics<<<kBlocks, kThreads>>>(counter32.get(), counter64.get(), sum.get(), popcounts.get(),
                                 extremes.get());
  EXPECT_EQ(counter32.copyOut()[0], kBlocks * kThreads);
  EXPECT_EQ(counter64.copyOut()[0], (1ull << 33) * kBlocks * kThreads);
  EXPECT_EQ(sum.copyOut()[0], 0.5f * kBlocks * kThreads);
  EXPECT_EQ(extremes.copyOut(), (std::vector<unsigned>{kBlocks * kThreads - 1, 0}));
  const std::vector<int> host = popcounts.copyOut();
  for (unsigned i = 0; i < kBlocks * kThreads; ++i) {
    ASSERT_EQ(host[i], 2 * __builtin_popcount(i)) << i;
  }
}

// --- collectives that cannot complete --------------------------------------

__global__ void laneExitsBeforeBallot(unsigned* out) {
  if (threadIdx.x == 5) return;
  out[threadIdx.x] = __ballot_sync(kFullWarp, 1);
}

TEST_F(CudaEmulationDeathTest, ALaneThatExitsBeforeACollectiveAborts) {
  Device<unsigned> out(32);
  EXPECT_DEATH(
      {
        laneExitsBeforeBallot<<<1, 32>>>(out.get());
        cudaDeviceSynchronize();
      },
      "kernel laneExitsBeforeBallot launched at .*cuda_emulation_test.cu:[0-9]+, block "
      "\\(0,0,0\\): thread \\(0,0,0\\) \\(warp 0, lane 0\\) waits at __ballot_sync \\(mask "
      "0xffffffff\\) at .*cuda_emulation_test.cu:[0-9]+ for thread \\(5,0,0\\) .* which exited");
}

__global__ void divergentCollectives(int* out) {
  const int lane = static_cast<int>(threadIdx.x);
  if (lane % 2 == 0) {
    out[lane] = __shfl_sync(kFullWarp, lane, 0);
  } else {
    out[lane] = static_cast<int>(__ballot_sync(kFullWarp, 1));
  }
}

TEST_F(CudaEmulationDeathTest, LanesAtDifferentCollectivesAbort) {
  Device<int> out(32);
  EXPECT_DEATH(
      {
        divergentCollectives<<<1, 32>>>(out.get());
        cudaDeviceSynchronize();
      },
      "thread \\(0,0,0\\) \\(warp 0, lane 0\\) waits at __shfl_sync \\(mask 0xffffffff\\) at "
      ".*cuda_emulation_test.cu:[0-9]+ while thread \\(1,0,0\\) \\(warp 0, lane 1\\) waits at "
      "__ballot_sync \\(mask 0xffffffff\\) .*the threads diverged");
}

__global__ void threadExitsBeforeBarrier(unsigned* out) {
  if (threadIdx.x == 40) return;
  __syncthreads();
  out[threadIdx.x] = 1;
}

TEST_F(CudaEmulationDeathTest, AThreadThatExitsBeforeSyncthreadsAborts) {
  Device<unsigned> out(64);
  EXPECT_DEATH(
      {
        threadExitsBeforeBarrier<<<1, 64>>>(out.get());
        cudaDeviceSynchronize();
      },
      "block \\(0,0,0\\): thread \\(0,0,0\\) .* waits at __syncthreads at "
      ".*cuda_emulation_test.cu:[0-9]+ for thread \\(40,0,0\\) \\(warp 1, lane 8\\), which exited");
}

__global__ void laneOutsideItsMask(unsigned* out) {
  if (threadIdx.x == 3) out[0] = __ballot_sync(0x1u, 1);
}

TEST_F(CudaEmulationDeathTest, ALaneOutsideItsOwnMaskAborts) {
  Device<unsigned> out(1);
  EXPECT_DEATH(
      {
        laneOutsideItsMask<<<1, 32>>>(out.get());
        cudaDeviceSynchronize();
      },
      "thread \\(3,0,0\\) \\(warp 0, lane 3\\) calls __ballot_sync \\(mask 0x00000001\\) .* "
      "outside its own mask");
}

__global__ void shuffleFromOutsideTheMask(int* out) {
  if (threadIdx.x < 16) out[threadIdx.x] = __shfl_sync(0x0000FFFFu, 1, 20);
}

TEST_F(CudaEmulationDeathTest, AShuffleReadingALaneOutsideTheMaskAborts) {
  Device<int> out(16);
  // Lane 20 of a full-width shuffle: source lane 20 is not in the mask.
  EXPECT_DEATH(
      {
        shuffleFromOutsideTheMask<<<1, 32>>>(out.get());
        cudaDeviceSynchronize();
      },
      "__shfl_sync \\(mask 0x0000ffff\\) .* reading lane 20, which is not in the mask");
}

// --- the coordinates outside a kernel ---------------------------------------

__device__ unsigned threadIndex() {
  return threadIdx.x;
}

TEST_F(CudaEmulationDeathTest, ReadingThreadIdxOutsideAKernelAborts) {
  EXPECT_DEATH(threadIndex(),
               "CUDA emulation: threadIdx, blockIdx, blockDim or gridDim read outside a kernel "
               "thread");
}

}  // namespace
