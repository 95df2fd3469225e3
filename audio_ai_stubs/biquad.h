// A second-order IIR low-pass filter: Robert Bristow-Johnson's "Audio EQ
// Cookbook" design, run in transposed direct form II.
//
// Each voice of the mixer owns one, so the filter keeps its own state (the two
// delay registers) and is cheap to copy.  Invariant: 0 < cutoff < sample_rate/2
// and q > 0, checked at construction; the coefficients are normalised (a0 = 1).
#pragma once

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace overlap::stubs {

class BiquadLowPass {
 public:
  // A pass-through filter, so a default-constructed voice is harmless.
  BiquadLowPass() = default;

  BiquadLowPass(double sample_rate, double cutoff_hz, double q) {
    if (!(sample_rate > 0.0) || !(cutoff_hz > 0.0) || !(cutoff_hz < sample_rate / 2.0) ||
        !(q > 0.0)) {
      throw std::invalid_argument("BiquadLowPass: need 0 < cutoff (" + std::to_string(cutoff_hz) +
                                  " Hz) < sample_rate/2 (" + std::to_string(sample_rate / 2.0) +
                                  " Hz) and q (" + std::to_string(q) + ") > 0");
    }
    const double w0 = 2.0 * std::numbers::pi * cutoff_hz / sample_rate;
    const double cos_w0 = std::cos(w0);
    const double alpha = std::sin(w0) / (2.0 * q);
    const double a0 = 1.0 + alpha;
    b0_ = static_cast<float>((1.0 - cos_w0) / 2.0 / a0);
    b1_ = static_cast<float>((1.0 - cos_w0) / a0);
    b2_ = b0_;
    a1_ = static_cast<float>(-2.0 * cos_w0 / a0);
    a2_ = static_cast<float>((1.0 - alpha) / a0);
  }

  float process(float input) {
    const float output = b0_ * input + z1_;
    z1_ = b1_ * input - a1_ * output + z2_;
    z2_ = b2_ * input - a2_ * output;
    return output;
  }

 private:
  float b0_ = 1.0f, b1_ = 0.0f, b2_ = 0.0f, a1_ = 0.0f, a2_ = 0.0f;
  float z1_ = 0.0f, z2_ = 0.0f;
};

}  // namespace overlap::stubs
