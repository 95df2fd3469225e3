// The CUDA emulation's internals shared by runtime.cpp (the API: memory,
// streams, events) and executor.cpp (running a grid): the fatal-error report
// and the grid runner.
#pragma once

#include <source_location>
#include <string>

#include "gpu/emulation/cuda_runtime.h"

namespace overlap::cuda_emulation::detail {

// "file:line" of a call site.
std::string where(const std::source_location& site);

// Prints "CUDA emulation: <message>" to stderr and aborts: a kernel or API
// misuse the emulation caught, which a GPU would not report so plainly.
[[noreturn]] void fail(const std::string& message);

// The OS threads that run blocks (OVERLAP_CUDA_EMULATION_THREADS, else every
// hardware thread), fixed at first use.
int workerThreadCount();

// Maps into the pool the fiber stacks that `launch`'s grid will take, one
// block's for each OS thread that runs it, or as many as the address space
// allows, so that a grid that runs never maps one; false when not even one
// block's fit (the launch then fails, as on a GPU that cannot allocate its
// local memory).
bool reserveStacks(const KernelLaunch& launch);

// Runs every block of a validated launch whose stacks are reserved, on as
// many OS threads as the pool holds stacks for, and returns when all are
// done.
void runGrid(const KernelLaunch& launch);

}  // namespace overlap::cuda_emulation::detail
