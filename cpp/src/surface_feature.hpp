#pragma once
// Internal: the pair feature on raw coordinates, shared by pair_feature() and PairIndex.
#include <cmath>

namespace pairgrasp::detail {

/// Writes (d, phi, beta_ij + beta_ji) of the oriented points (pi, ni), (pj, nj) to out[0..2].
/// Every operation is symmetric in i and j term by term, so swapping them gives the same bits.
inline void pair_feature_raw(const double* pi, const double* ni, const double* pj, const double* nj,
                             double* out) {
  const double dx = pi[0] - pj[0], dy = pi[1] - pj[1], dz = pi[2] - pj[2];
  const double d = std::sqrt(dx * dx + dy * dy + dz * dz);
  out[0] = d;
  out[1] = ni[0] * nj[0] + ni[1] * nj[1] + ni[2] * nj[2];
  out[2] = d > 0.0 ? ((ni[0] - nj[0]) * dx + (ni[1] - nj[1]) * dy + (ni[2] - nj[2]) * dz) / d : 0.0;
}

}  // namespace pairgrasp::detail
