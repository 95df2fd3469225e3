// The CUDA emulation's cub::DeviceScan::ExclusiveSum (see cub/cub.cuh): out[i]
// is the sum of in[0..i), accumulated in the input's value type, on the CPU in
// the stream's order.  d_in may equal d_out, as CUB allows.
#pragma once

#include <cstddef>
#include <iterator>

#include "cub/host_work.h"

namespace cub {

struct DeviceScan {
  template <class InputIteratorT, class OutputIteratorT, class NumItemsT>
  static cudaError_t ExclusiveSum(void* d_temp_storage, std::size_t& temp_storage_bytes,
                                  InputIteratorT d_in, OutputIteratorT d_out, NumItemsT num_items,
                                  cudaStream_t stream = 0) {
    const auto count = static_cast<std::size_t>(num_items);
    return emulation::runWithTempStorage(
        d_temp_storage, temp_storage_bytes, emulation::kSmallTempStorageBytes, stream, [=] {
          using Value = std::iter_value_t<InputIteratorT>;
          Value sum{};
          for (std::size_t i = 0; i < count; ++i) {
            const Value item = d_in[i];  // read before the write: in place is allowed
            d_out[i] = sum;
            sum = static_cast<Value>(sum + item);
          }
        });
  }
};

}  // namespace cub
