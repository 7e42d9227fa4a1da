#pragma once
// Random draws with a fixed algorithm on top of std::mt19937_64 (whose sequence the C++ standard
// fixes), so that seeded searches give the same result on every platform.
#include <Eigen/Core>

#include <cmath>
#include <random>

namespace pairgrasp::detail {

// Uniform double in [0, 1) from 53 random bits.
inline double uniform01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }
inline double uniform(std::mt19937_64& rng, double lo, double hi) { return lo + (hi - lo) * uniform01(rng); }

// Standard normal by the Box-Muller transform (one value per call; std::normal_distribution's
// algorithm is implementation-defined, this is not).
inline double normal(std::mt19937_64& rng) {
  const double u1 = 1.0 - uniform01(rng);  // (0, 1]
  const double u2 = uniform01(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * 3.14159265358979323846 * u2);
}

inline Eigen::Vector3d unit_vector(std::mt19937_64& rng) {
  for (;;) {
    const Eigen::Vector3d v(normal(rng), normal(rng), normal(rng));
    const double n = v.norm();
    if (n > 1e-12) return v / n;
  }
}

}  // namespace pairgrasp::detail
