// Included by broadmark_driver.cpp after Broadmark's Core/Math/SIMD.h and
// right before its SAP headers, then the macro is undefined.  Broadmark's
// SIMD sweeps (SAP_SIMD.h, SAP_SIMD_Parallel.h) pass *(__m256*)&m_min[axis][j],
// a float at any j, straight to SIMD::IsGreater's const __m256& parameter.
// MSVC loads it unaligned; clang loads a reference's vector with vmovaps,
// which faults when j is not a multiple of the width.  The macro hands
// IsGreater the same value through an unaligned load; the test is Broadmark's.
#pragma once

#include <immintrin.h>

namespace broadmark_compat {

inline __m128 loadUnaligned(const __m128* vector) {
  return _mm_loadu_ps(reinterpret_cast<const float*>(vector));
}
inline __m256 loadUnaligned(const __m256* vector) {
  return _mm256_loadu_ps(reinterpret_cast<const float*>(vector));
}

}  // namespace broadmark_compat

#define IsGreater(a, b) IsGreater(broadmark_compat::loadUnaligned(&(a)), b)
