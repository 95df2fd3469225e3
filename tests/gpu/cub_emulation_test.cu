// The CUDA emulation's CUB stand-ins (gpu/emulation/cub/) against the
// standard library: stable radix sorts on bit ranges, the exclusive sum and
// the selection, at CUB's tile boundaries and beyond, with repeated keys; the
// temporary-storage protocol; and that their work waits, like a kernel, for
// its stream.  Emulation build only.
#include <cuda_runtime.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cub/cub.cuh>
#include <cuda/std/tuple>
#include <numeric>
#include <random>
#include <vector>

namespace {

const std::size_t kSizes[] = {0, 1, 31, 32, 33, 1023, 1025, 4096, 200000};

// A device copy of a host vector, freed at scope exit.
template <class T>
class DeviceArray {
 public:
  explicit DeviceArray(const std::vector<T>& from) : count_(from.size()) {
    EXPECT_EQ(cudaMalloc(reinterpret_cast<void**>(&data_), bytes()), cudaSuccess);
    if (count_ > 0) {
      EXPECT_EQ(cudaMemcpy(data_, from.data(), bytes(), cudaMemcpyHostToDevice), cudaSuccess);
    }
  }
  explicit DeviceArray(std::size_t count) : DeviceArray(std::vector<T>(count)) {}
  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;
  ~DeviceArray() { cudaFree(data_); }

  T* data() const { return data_; }
  // Waits for the device (a blocking copy on the legacy stream waits for the
  // others' work only through a synchronize, so synchronize first).
  std::vector<T> toHost(std::size_t count) const {
    EXPECT_EQ(cudaDeviceSynchronize(), cudaSuccess);
    std::vector<T> result(count);
    if (count > 0) {
      EXPECT_EQ(cudaMemcpy(result.data(), data_, count * sizeof(T), cudaMemcpyDeviceToHost),
                cudaSuccess);
    }
    return result;
  }
  std::vector<T> toHost() const { return toHost(count_); }

 private:
  std::size_t bytes() const { return count_ * sizeof(T); }
  T* data_ = nullptr;
  std::size_t count_ = 0;
};

// Temporary storage for one call, sized by the call's own query.
class TempStorage {
 public:
  ~TempStorage() { cudaFree(data_); }
  template <class Call>
  cudaError_t run(Call call) {
    std::size_t bytes = 0;
    const cudaError_t query = call(nullptr, bytes);
    if (query != cudaSuccess) return query;
    EXPECT_GT(bytes, 0u);
    cudaFree(data_);
    EXPECT_EQ(cudaMalloc(&data_, bytes), cudaSuccess);
    return call(data_, bytes);
  }

 private:
  void* data_ = nullptr;
};

// Keys with many repeats (stability shows) spread over all 64 bits.
template <class Key>
std::vector<Key> repeatingKeys(std::size_t count, unsigned seed) {
  std::mt19937_64 random(seed);
  std::vector<Key> distinct(count / 8 + 1);
  for (Key& key : distinct) key = static_cast<Key>(random());
  std::vector<Key> keys(count);
  for (Key& key : keys) key = distinct[random() % distinct.size()];
  return keys;
}

// The key with every bit outside [begin_bit, end_bit) cleared: it orders
// keys as their bits in the range do.
template <class Key>
Key inRange(Key key, int begin_bit, int end_bit) {
  Key mask = 0;
  for (int bit = begin_bit; bit < end_bit; ++bit) mask |= static_cast<Key>(Key{1} << bit);
  return key & mask;
}

// std::stable_sort's order of (key, index) pairs by the bit range.
template <class Key>
std::vector<std::pair<Key, std::uint32_t>> expectedPairs(const std::vector<Key>& keys,
                                                         int begin_bit, int end_bit) {
  std::vector<std::pair<Key, std::uint32_t>> pairs;
  for (std::uint32_t i = 0; i < keys.size(); ++i) pairs.emplace_back(keys[i], i);
  std::stable_sort(pairs.begin(), pairs.end(), [&](const auto& x, const auto& y) {
    return inRange(x.first, begin_bit, end_bit) < inRange(y.first, begin_bit, end_bit);
  });
  return pairs;
}

struct BitRange {
  int begin_bit;
  int end_bit;
};

TEST(CubStandIns, SortPairsIsStableOnTheBitRange) {
  for (const std::size_t n : kSizes) {
    for (const BitRange bits : {BitRange{0, 32}, BitRange{4, 13}, BitRange{0, 7}}) {
      SCOPED_TRACE(::testing::Message()
                   << n << " keys, bits " << bits.begin_bit << ".." << bits.end_bit);
      const std::vector<std::uint32_t> keys = repeatingKeys<std::uint32_t>(n, 1);
      std::vector<std::uint32_t> values(n);
      std::iota(values.begin(), values.end(), 0u);
      const DeviceArray<std::uint32_t> keys_in(keys), values_in(values), keys_out(n), values_out(n);
      TempStorage temp;
      ASSERT_EQ(temp.run([&](void* storage, std::size_t& bytes) {
        return cub::DeviceRadixSort::SortPairs(storage, bytes, keys_in.data(), keys_out.data(),
                                               values_in.data(), values_out.data(), n,
                                               bits.begin_bit, bits.end_bit, cudaStream_t{});
      }),
                cudaSuccess);
      const auto expected = expectedPairs(keys, bits.begin_bit, bits.end_bit);
      const std::vector<std::uint32_t> sorted_keys = keys_out.toHost();
      const std::vector<std::uint32_t> sorted_values = values_out.toHost();
      for (std::size_t i = 0; i < n; ++i) {
        ASSERT_EQ(sorted_keys[i], expected[i].first) << "at " << i;
        ASSERT_EQ(sorted_values[i], expected[i].second) << "at " << i;
      }
      EXPECT_EQ(keys_in.toHost(), keys) << "the pointer form leaves its input alone";
    }
  }
}

// Bit ranges of an odd and an even pass count: the result is wherever
// Current() says, never assumed.
TEST(CubStandIns, DoubleBufferSortsEndWhereTheSelectorSays) {
  for (const std::size_t n : kSizes) {
    for (const BitRange bits : {BitRange{0, 64}, BitRange{0, 40}, BitRange{20, 52}}) {
      SCOPED_TRACE(::testing::Message()
                   << n << " keys, bits " << bits.begin_bit << ".." << bits.end_bit);
      const std::vector<std::uint64_t> keys = repeatingKeys<std::uint64_t>(n, 2);
      std::vector<std::uint32_t> values(n);
      std::iota(values.begin(), values.end(), 0u);
      const DeviceArray<std::uint64_t> keys_a(keys), keys_b(n), keys_only_a(keys), keys_only_b(n);
      const DeviceArray<std::uint32_t> values_a(values), values_b(n);
      cub::DoubleBuffer<std::uint64_t> key_buffers(keys_a.data(), keys_b.data());
      cub::DoubleBuffer<std::uint32_t> value_buffers(values_a.data(), values_b.data());
      cub::DoubleBuffer<std::uint64_t> lone_keys(keys_only_a.data(), keys_only_b.data());
      TempStorage temp;
      ASSERT_EQ(temp.run([&](void* storage, std::size_t& bytes) {
        return cub::DeviceRadixSort::SortPairs(storage, bytes, key_buffers, value_buffers, n,
                                               bits.begin_bit, bits.end_bit, cudaStream_t{});
      }),
                cudaSuccess);
      ASSERT_EQ(temp.run([&](void* storage, std::size_t& bytes) {
        return cub::DeviceRadixSort::SortKeys(storage, bytes, lone_keys, n, bits.begin_bit,
                                              bits.end_bit, cudaStream_t{});
      }),
                cudaSuccess);
      EXPECT_EQ(key_buffers.selector, value_buffers.selector);
      const auto expected = expectedPairs(keys, bits.begin_bit, bits.end_bit);
      const auto& sorted_keys = key_buffers.selector == 0 ? keys_a : keys_b;
      const auto& sorted_values = value_buffers.selector == 0 ? values_a : values_b;
      const auto& sorted_lone = lone_keys.selector == 0 ? keys_only_a : keys_only_b;
      const std::vector<std::uint64_t> got_keys = sorted_keys.toHost();
      const std::vector<std::uint32_t> got_values = sorted_values.toHost();
      const std::vector<std::uint64_t> got_lone = sorted_lone.toHost();
      for (std::size_t i = 0; i < n; ++i) {
        ASSERT_EQ(got_keys[i], expected[i].first) << "at " << i;
        ASSERT_EQ(got_values[i], expected[i].second) << "at " << i;
        ASSERT_EQ(got_lone[i], expected[i].first) << "at " << i;
      }
    }
  }
}

TEST(CubStandIns, SortKeysMatchesStdSort) {
  for (const std::size_t n : kSizes) {
    SCOPED_TRACE(::testing::Message() << n << " keys");
    const std::vector<std::uint64_t> keys = repeatingKeys<std::uint64_t>(n, 3);
    const DeviceArray<std::uint64_t> keys_in(keys), keys_out(n);
    TempStorage temp;
    ASSERT_EQ(temp.run([&](void* storage, std::size_t& bytes) {
      return cub::DeviceRadixSort::SortKeys(storage, bytes, keys_in.data(), keys_out.data(), n);
    }),
              cudaSuccess);
    std::vector<std::uint64_t> expected = keys;
    std::sort(expected.begin(), expected.end());
    EXPECT_EQ(keys_out.toHost(), expected);
  }
}

// A key of two members, sorted through a decomposer: `high` the more
// significant, the bit range over both as one 64-bit number.
struct TwoPartKey {
  std::uint32_t high;
  std::uint32_t low;
};

struct TwoPartBits {
  ::cuda::std::tuple<std::uint32_t&, std::uint32_t&> operator()(TwoPartKey& key) const {
    return ::cuda::std::tie(key.high, key.low);
  }
};

TEST(CubStandIns, SortKeysThroughADecomposerOrdersByTheMembersBitsAsOneKey) {
  for (const std::size_t n : kSizes) {
    SCOPED_TRACE(::testing::Message() << n << " keys");
    std::vector<TwoPartKey> keys(n);
    std::mt19937 random(6);
    for (TwoPartKey& key : keys)
      key = {static_cast<std::uint32_t>(random()), static_cast<std::uint32_t>(random() % 64u)};
    const auto bits = [](const TwoPartKey& key) {  // [0, 38): low, then high's 6 lowest bits
      return (std::uint64_t{key.high & 63u} << 32) | key.low;
    };
    std::vector<TwoPartKey> expected = keys;
    std::stable_sort(expected.begin(), expected.end(),
                     [&](const TwoPartKey& x, const TwoPartKey& y) { return bits(x) < bits(y); });
    const DeviceArray<TwoPartKey> keys_a(keys), keys_b(n);
    cub::DoubleBuffer<TwoPartKey> buffers(keys_a.data(), keys_b.data());
    TempStorage temp;
    ASSERT_EQ(temp.run([&](void* storage, std::size_t& bytes) {
      return cub::DeviceRadixSort::SortKeys(storage, bytes, buffers, n, TwoPartBits{}, 0, 38);
    }),
              cudaSuccess);
    const std::vector<TwoPartKey> got = (buffers.selector == 0 ? keys_a : keys_b).toHost();
    ASSERT_EQ(got.size(), expected.size());
    for (std::size_t i = 0; i < n; ++i) {
      EXPECT_TRUE(got[i].high == expected[i].high && got[i].low == expected[i].low) << i;
    }
  }
}

TEST(CubStandIns, ExclusiveSumMatchesStdExclusiveScanAlsoInPlace) {
  for (const std::size_t n : kSizes) {
    SCOPED_TRACE(::testing::Message() << n << " items");
    std::vector<std::uint32_t> items(n);
    std::mt19937 random(4);
    for (std::uint32_t& item : items) item = static_cast<std::uint32_t>(random() % 1000u);
    std::vector<std::uint32_t> expected(n);
    std::exclusive_scan(items.begin(), items.end(), expected.begin(), 0u);
    const DeviceArray<std::uint32_t> in(items), out(n), in_place(items);
    TempStorage temp;
    ASSERT_EQ(temp.run([&](void* storage, std::size_t& bytes) {
      return cub::DeviceScan::ExclusiveSum(storage, bytes, in.data(), out.data(), n);
    }),
              cudaSuccess);
    ASSERT_EQ(temp.run([&](void* storage, std::size_t& bytes) {
      return cub::DeviceScan::ExclusiveSum(storage, bytes, in_place.data(), in_place.data(), n);
    }),
              cudaSuccess);
    EXPECT_EQ(out.toHost(), expected);
    EXPECT_EQ(in_place.toHost(), expected);
  }
}

struct IsOdd {
  bool operator()(std::uint64_t item) const { return item % 2 == 1; }
};

TEST(CubStandIns, SelectIfMatchesStdCopyIfAlsoInPlace) {
  for (const std::size_t n : kSizes) {
    SCOPED_TRACE(::testing::Message() << n << " items");
    const std::vector<std::uint64_t> items = repeatingKeys<std::uint64_t>(n, 5);
    std::vector<std::uint64_t> expected;
    std::copy_if(items.begin(), items.end(), std::back_inserter(expected), IsOdd{});
    const DeviceArray<std::uint64_t> in(items), out(n), in_place(items);
    const DeviceArray<std::uint32_t> counts(2);
    TempStorage temp;
    ASSERT_EQ(temp.run([&](void* storage, std::size_t& bytes) {
      return cub::DeviceSelect::If(storage, bytes, in.data(), out.data(), counts.data(),
                                   static_cast<std::int64_t>(n), IsOdd{}, cudaStream_t{});
    }),
              cudaSuccess);
    ASSERT_EQ(temp.run([&](void* storage, std::size_t& bytes) {
      return cub::DeviceSelect::If(storage, bytes, in_place.data(), counts.data() + 1,
                                   static_cast<std::int64_t>(n), IsOdd{}, cudaStream_t{});
    }),
              cudaSuccess);
    const std::vector<std::uint32_t> selected = counts.toHost();
    EXPECT_EQ(selected[0], expected.size());
    EXPECT_EQ(selected[1], expected.size());
    EXPECT_EQ(out.toHost(expected.size()), expected);
    EXPECT_EQ(in_place.toHost(expected.size()), expected);
  }
}

TEST(CubStandIns, TooLittleTempStorageIsRefusedAndNothingRuns) {
  const std::vector<std::uint32_t> items = {3, 1, 2};
  const DeviceArray<std::uint32_t> in(items), out(std::vector<std::uint32_t>{7, 7, 7});
  std::size_t needed = 0;
  ASSERT_EQ(cub::DeviceRadixSort::SortKeys(nullptr, needed, in.data(), out.data(), 3), cudaSuccess);
  ASSERT_GT(needed, 1u);
  void* storage = nullptr;
  ASSERT_EQ(cudaMalloc(&storage, needed), cudaSuccess);
  std::size_t too_few = needed - 1;
  EXPECT_EQ(cub::DeviceRadixSort::SortKeys(storage, too_few, in.data(), out.data(), 3),
            cudaErrorInvalidValue);
  EXPECT_EQ(cub::DeviceRadixSort::SortKeys(storage, needed, in.data(), out.data(), 3, 0, 33),
            cudaErrorInvalidValue)
      << "a bit range past the key's width";
  EXPECT_EQ(out.toHost(), (std::vector<std::uint32_t>{7, 7, 7}));
  cudaFree(storage);
}

// The work waits for the stream, in order after a kernel-like copy before it,
// and runs only when the stream is waited for.
TEST(CubStandIns, WorkRunsInTheStreamsOrderWhenWaitedFor) {
  cudaStream_t stream = nullptr;
  ASSERT_EQ(cudaStreamCreateWithFlags(&stream, cudaStreamNonBlocking), cudaSuccess);
  const std::vector<std::uint32_t> items = {5, 6, 7};
  const DeviceArray<std::uint32_t> source(items), in(std::vector<std::uint32_t>{0, 0, 0}), out(3);
  std::uint32_t* pinned = nullptr;
  ASSERT_EQ(cudaMallocHost(reinterpret_cast<void**>(&pinned), 3 * sizeof(std::uint32_t)),
            cudaSuccess);
  ASSERT_EQ(cudaMemcpyAsync(in.data(), source.data(), 3 * sizeof(std::uint32_t),
                            cudaMemcpyDeviceToDevice, stream),
            cudaSuccess);
  std::size_t bytes = 0;
  ASSERT_EQ(cub::DeviceScan::ExclusiveSum(nullptr, bytes, in.data(), out.data(), 3, stream),
            cudaSuccess);
  void* storage = nullptr;
  ASSERT_EQ(cudaMalloc(&storage, bytes), cudaSuccess);
  ASSERT_EQ(cub::DeviceScan::ExclusiveSum(storage, bytes, in.data(), out.data(), 3, stream),
            cudaSuccess);
  ASSERT_EQ(cudaMemcpyAsync(pinned, out.data(), 3 * sizeof(std::uint32_t), cudaMemcpyDeviceToHost,
                            stream),
            cudaSuccess);
  EXPECT_EQ(pinned[0], 0xA5A5A5A5u) << "nothing has run before the host waits";
  ASSERT_EQ(cudaStreamSynchronize(stream), cudaSuccess);
  EXPECT_EQ(std::vector<std::uint32_t>(pinned, pinned + 3), (std::vector<std::uint32_t>{0, 5, 11}));
  cudaFreeHost(pinned);
  cudaFree(storage);
  cudaStreamDestroy(stream);
}

}  // namespace

// BlockRadixSort: one block's keys, blocked, sorted by a bit range, stably.
template <int kThreads, int kItems>
__global__ void sortBlockKernel(std::uint64_t* keys, int begin_bit, int end_bit) {
  using Sort = cub::BlockRadixSort<std::uint64_t, kThreads, kItems>;
  __shared__ typename Sort::TempStorage storage;
  std::uint64_t mine[kItems];
  for (int item = 0; item < kItems; ++item) mine[item] = keys[threadIdx.x * kItems + item];
  Sort(storage).Sort(mine, begin_bit, end_bit);
  for (int item = 0; item < kItems; ++item) keys[threadIdx.x * kItems + item] = mine[item];
}

template <int kThreads, int kItems>
void expectBlockSortMatchesStableSort(int begin_bit, int end_bit, std::uint64_t seed) {
  std::mt19937_64 random(seed);
  std::vector<std::uint64_t> keys(kThreads * kItems);
  // Few distinct digits on the range, so stability shows.
  for (std::uint64_t& key : keys) key = random() & 0xF0F0F0F0F0F0F0F0ull;
  std::vector<std::uint64_t> expected = keys;
  const auto digits = [&](std::uint64_t key) {
    const std::uint64_t shifted = key >> begin_bit;
    const int width = end_bit - begin_bit;
    return width >= 64 ? shifted : shifted & ((std::uint64_t{1} << width) - 1);
  };
  std::stable_sort(expected.begin(), expected.end(),
                   [&](std::uint64_t x, std::uint64_t y) { return digits(x) < digits(y); });
  DeviceArray<std::uint64_t> device(keys);
  sortBlockKernel<kThreads, kItems><<<1, kThreads>>>(device.data(), begin_bit, end_bit);
  ASSERT_EQ(cudaGetLastError(), cudaSuccess);
  EXPECT_EQ(device.toHost(), expected)
      << kThreads << " threads x " << kItems << " keys, bits " << begin_bit << ".." << end_bit;
}

TEST(CubStandIns, BlockRadixSortMatchesStableSortOnTheBitRange) {
  for (const auto& [begin_bit, end_bit] : {std::pair{0, 64}, {0, 24}, {8, 40}, {4, 5}}) {
    expectBlockSortMatchesStableSort<32, 1>(begin_bit, end_bit, 1);
    expectBlockSortMatchesStableSort<32, 33>(begin_bit, end_bit, 2);
    expectBlockSortMatchesStableSort<512, 8>(begin_bit, end_bit, 3);
  }
}
