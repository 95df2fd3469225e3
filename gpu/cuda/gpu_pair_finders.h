// Constructors of the GPU finders, kept free of CUDA types so that
// pair_finder.cpp and the tests compile with the host compiler alone.  In a
// build without CUDA they throw std::runtime_error ("built without CUDA").
#pragma once

#include <memory>

#include "gpu/pair_finder.h"

namespace overlap::finders {

// gpubf: bits, XOR and compaction on the GPU; only the changes cross the bus.
std::unique_ptr<PairFinder> makeGpuPairFinder();

// gpubf-paper: Serpa & Rodrigues's algorithm, one byte per pair copied back
// whole every frame and compared on the host.
std::unique_ptr<PairFinder> makePaperGpuPairFinder();

// gpusap: sort and sweep on the GPU with CUB; the pair set stays on the
// device and only the changes, found there and sorted, cross the bus.
std::unique_ptr<PairFinder> makeGpuSapPairFinder();

}  // namespace overlap::finders
