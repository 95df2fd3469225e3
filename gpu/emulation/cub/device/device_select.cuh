// The CUDA emulation's cub::DeviceSelect::If (see cub/cub.cuh): the items for
// which select_op holds, in their input order, to d_out (or to the front of
// d_data, in place) and their count to *d_num_selected_out, on the CPU in the
// stream's order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "cub/host_work.h"

namespace cub {

struct DeviceSelect {
  template <class InputIteratorT, class OutputIteratorT, class NumSelectedIteratorT, class SelectOp>
  static cudaError_t If(void* d_temp_storage, std::size_t& temp_storage_bytes, InputIteratorT d_in,
                        OutputIteratorT d_out, NumSelectedIteratorT d_num_selected_out,
                        std::int64_t num_items, SelectOp select_op, cudaStream_t stream = 0) {
    if (num_items < 0) return cudaErrorInvalidValue;
    return emulation::runWithTempStorage(
        d_temp_storage, temp_storage_bytes, emulation::kSmallTempStorageBytes, stream, [=] {
          std::int64_t selected = 0;
          for (std::int64_t i = 0; i < num_items; ++i) {
            const auto item = d_in[i];  // read before the write: in place, out never passes in
            if (select_op(item)) d_out[selected++] = item;
          }
          *d_num_selected_out =
              static_cast<std::remove_reference_t<decltype(*d_num_selected_out)>>(selected);
        });
  }

  // In place: the selected items move to the front of d_data.
  template <class IteratorT, class NumSelectedIteratorT, class SelectOp>
  static cudaError_t If(void* d_temp_storage, std::size_t& temp_storage_bytes, IteratorT d_data,
                        NumSelectedIteratorT d_num_selected_out, std::int64_t num_items,
                        SelectOp select_op, cudaStream_t stream = 0) {
    return If(d_temp_storage, temp_storage_bytes, d_data, d_data, d_num_selected_out, num_items,
              select_op, stream);
  }
};

}  // namespace cub
