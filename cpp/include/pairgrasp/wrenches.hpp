#pragma once
/// @file wrenches.hpp
/// Contact wrenches of point contacts with Coulomb friction (paper eq. 2-5), in GraspIt's
/// convention: the C++ side of `pairgrasp.grasp_quality` (the hull and epsilon are computed in
/// Python with qhull).
#include <pairgrasp/types.hpp>

namespace pairgrasp {

/// W x 6 wrenches, one per row: [f; (p - c) x f / r].
using Wrenches = Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>;

/// The friction-pyramid wrenches of contacts `points` (N,3, metres) with the target's OUTWARD
/// unit normals `normals` (N,3; fingers push along -normal). Contact i gives rows
/// i*edges .. i*edges+edges-1: edge k is f = n_in + mu (cos(2 pi k/edges) t1 + sin(2 pi k/edges) t2)
/// with n_in = -normal, t1 the coordinate axis least aligned with n_in (lowest index on a tie)
/// projected onto the tangent plane and normalised, t2 = n_in x t1; its wrench is
/// [f; (p - center) x f / radius] (radius in metres makes the torque part dimensionless).
/// Throws std::invalid_argument for mismatched sizes, non-finite values, a zero-length normal,
/// radius <= 0, mu < 0 or edges < 3.
Wrenches wrench_matrix(const Points& points, const Points& normals, const Eigen::Vector3d& center,
                       double radius, double mu = 0.5, int edges = 8);

}  // namespace pairgrasp
