// The CUDA emulation's <cub/cub.cuh>: CPU stand-ins for the few CUB
// device-wide algorithms gpu/cuda/*.cu use, with CUB's signatures and contracts,
// so that the .cu files compile unchanged against them (this directory is on
// the emulation build's include path ahead of the toolkit).  The one
// block-wide collective used, cub/block/block_radix_sort.cuh, states its own.
//
// Contracts kept, each as CUB states it:
// - a call with d_temp_storage == nullptr only writes the temporary storage
//   it needs to temp_storage_bytes and does no work; a call with too little
//   storage returns cudaErrorInvalidValue and enqueues nothing;
// - the work runs on `stream`, in its order, when the stream is waited for
//   (the emulation's streams are lazy: cudaLaunchHostFunc), reading its
//   inputs then, not at the call; host arguments (num_items, bit range,
//   DoubleBuffer selectors) are taken at the call, as CUB takes them;
// - radix sorts are stable and order by bits [begin_bit, end_bit) alone;
//   scans and selections keep the input's order.
// What the stand-ins add, so that a caller's mistake shows here: the whole
// temporary storage is overwritten with garbage each call (an undersized
// buffer is an out-of-bounds write under ASan), and a DoubleBuffer sort
// leaves garbage in the buffer that does not hold the result.  The
// stand-ins cover unsigned integer keys only; the rest of CUB is absent.
#pragma once

#include "cub/block/block_radix_sort.cuh"
#include "cub/device/device_radix_sort.cuh"
#include "cub/device/device_scan.cuh"
#include "cub/device/device_select.cuh"
#include "cub/util_type.cuh"
