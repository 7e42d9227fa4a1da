#pragma once
// How many random cases the brute-force comparisons draw. The plain build draws them all; a
// sanitizer build (PAIRGRASP_SANITIZED, 10-30x slower) draws a quarter: the same code paths for
// memory and undefined-behaviour errors, at a cost CI can afford. Correctness is the plain run's.
namespace pairgrasp::testing_scale {

#ifdef PAIRGRASP_SANITIZED
inline constexpr int kDivisor = 4;
#else
inline constexpr int kDivisor = 1;
#endif

/// n random cases in the plain build, n / kDivisor (at least 1) under the sanitizers.
constexpr int cases(int n) { return n / kDivisor > 0 ? n / kDivisor : 1; }

}  // namespace pairgrasp::testing_scale
