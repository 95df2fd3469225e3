// Seeded random numbers that give the same sequence on every machine.
//
// std::uniform_real_distribution and friends are implementation-defined, so a
// seed would give different scenes with different standard libraries.  These
// helpers map std::mt19937_64's fully specified output to numbers themselves.
#pragma once

#include <cstdint>
#include <random>

namespace overlap {

class SeededRandom {
 public:
  explicit SeededRandom(std::uint64_t seed) : engine_(seed) {}

  // Uniform in [0, 1), from the top 53 bits.
  double unit() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }

  double uniform(double lo, double hi) { return lo + (hi - lo) * unit(); }

  // Uniform integer in [0, n), n > 0, without modulo bias: draws past the
  // largest multiple of n are rejected.
  std::uint64_t below(std::uint64_t n) {
    const std::uint64_t rejected_from = UINT64_MAX - UINT64_MAX % n;
    for (;;) {
      const std::uint64_t draw = engine_();
      if (draw < rejected_from) return draw % n;
    }
  }

 private:
  std::mt19937_64 engine_;
};

}  // namespace overlap
