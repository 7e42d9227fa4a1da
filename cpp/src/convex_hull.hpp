#pragma once
// Convex hulls by qhull's reentrant library, one qhull state per call (thread safe). Internal.
#include <Eigen/Core>

#include <string>
#include <vector>

namespace pairgrasp::detail {

/// A hull's facets and vertices, as qhull reports them.
struct ConvexHull {
  /// One row per facet: unit outward normal a (dim values) and offset b, a.x + b <= 0 inside.
  Eigen::MatrixXd planes;
  double volume = 0.0;       ///< hull volume (when asked for)
  std::vector<int> vertices; ///< indices of the input points that are hull vertices, ascending
};

/// The hull of `n` points of dimension `dim` (row-major `points`, n*dim values) with the qhull
/// options `options` (e.g. "Qt Qx"). Returns false on a qhull error (precision, flat input ...)
/// with the first line of qhull's message in `error`. Throws std::bad_alloc when qhull runs out
/// of memory.
bool convex_hull(const double* points, int n, int dim, const std::string& options, bool volume, ConvexHull& out,
                 std::string& error);

}  // namespace pairgrasp::detail
