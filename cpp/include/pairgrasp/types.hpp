#pragma once
/// @file types.hpp
/// Eigen types shared by the public headers. Row-major (N,3) blocks so that NumPy sees them
/// without a copy. All lengths are in metres, all angles in radians.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>

namespace pairgrasp {

/// N points or vectors, one per row, metres (points) or unit length (normals).
using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// F triangles, one per row, as indices into a Points block.
using Triangles = Eigen::Matrix<std::int32_t, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// A per-element yes/no mask (e.g. free = reachable facets).
using Mask = Eigen::Matrix<bool, Eigen::Dynamic, 1>;
/// A rigid transform: p_parent = T * p_child.
using Pose = Eigen::Isometry3d;

}  // namespace pairgrasp
