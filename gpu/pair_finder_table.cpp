// The table of finders (gpu/pair_finder.h, PairFinderRow): one row per
// finder.  Adding a finder is its own file (a PairFinder and a function that
// makes one) plus its row here; nothing else names it.
#include <memory>

#include "gpu/cpu/cpu_brute_force.h"
#include "gpu/cpu/cpu_sweep_and_prune.h"
#include "gpu/pair_finder.h"

namespace overlap::finders {

#if OVERLAP_HAVE_CUDA
// Defined in the GPU finders' own .cu files.
std::unique_ptr<PairFinder> makeGpuBruteForceFinder(TaskSystem& tasks);
std::unique_ptr<PairFinder> makePaperBruteForceFinder(TaskSystem& tasks);
std::unique_ptr<PairFinder> makeGpuSweepAndPruneFinder(TaskSystem& tasks);
#define OVERLAP_GPU_FINDER(make) make
#else
// Never called: makePairFinder() refuses a device finder without a device.
#define OVERLAP_GPU_FINDER(make) nullptr
#endif

namespace {

template <class Finder>
std::unique_ptr<PairFinder> makeCpuFinder(TaskSystem& tasks) {
  return std::make_unique<Finder>(tasks);
}

constexpr PairFinderRow kTable[] = {
    {"cpubf",
     false,
     "ours: brute force on CPU threads, gpubf's twin and the reference",
     makeCpuFinder<CpuBruteForceFinder>,
     {.per_slot = 64, .per_slot_pair = 1.0 / 8, .per_pair = 48}},
    {"cpusap",
     false,
     "ours: sort and sweep on CPU threads (AVX2), the fastest exact CPU finder",
     makeCpuFinder<CpuSweepAndPruneFinder>,
     {.per_slot = 160, .per_pair = 96}},
    {"gpubf",
     true,
     "ours: CUDA brute force, pairs as bits, only the changes copied back",
     OVERLAP_GPU_FINDER(makeGpuBruteForceFinder),
     {.per_slot = 96, .per_slot_pair = 2.0 / 8, .per_pair = 48}},
    {"gpubf-paper",
     true,
     "the paper's CUDA brute force as published: a byte per pair, all copied back",
     OVERLAP_GPU_FINDER(makePaperBruteForceFinder),
     {.per_slot = 96, .per_slot_pair = 3, .per_pair = 32}},
    {"gpusap",
     true,
     "ours: CUDA sort and sweep (CUB), pairs kept on the device, only the changes copied back",
     OVERLAP_GPU_FINDER(makeGpuSweepAndPruneFinder),
     {.per_slot = 256, .per_pair = 96}},
};

}  // namespace

std::span<const PairFinderRow> pairFinderTable() {
  return kTable;
}

}  // namespace overlap::finders
