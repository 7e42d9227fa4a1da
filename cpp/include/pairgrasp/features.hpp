#pragma once
/// @file features.hpp
/// The pairwise feature of the paper (eq. 9-12).
#include <Eigen/Core>

namespace pairgrasp {

/// e = (d, phi, beta_ij + beta_ji) for oriented points (p_i, n_i), (p_j, n_j):
/// d = |p_i - p_j| (m), phi = n_i . n_j, beta_ij + beta_ji = (n_i - n_j) . (p_i - p_j) / d.
/// Symmetric in i and j (bit for bit). For d == 0 the third component is 0.
/// Throws std::invalid_argument for non-finite input or a normal whose length is not 1 (to 1e-6).
Eigen::Vector3d pair_feature(const Eigen::Vector3d& p_i, const Eigen::Vector3d& n_i,
                             const Eigen::Vector3d& p_j, const Eigen::Vector3d& n_j);

}  // namespace pairgrasp
