#pragma once
/// @file facets.hpp
/// Unit facets: a surface re-sampled into pieces of roughly equal area (edge length h).
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/types.hpp>

namespace pairgrasp {

/// A surface as unit facets. Row k of every block describes facet k.
struct UnitFacets {
  Points points;               ///< (N,3) facet centres on the surface, metres
  Points normals;              ///< (N,3) unit outward normals
  Eigen::VectorXd areas;       ///< (N) facet areas, m^2
  Eigen::VectorXi face_ids;    ///< (N) index of the source mesh face holding the centre
  Mask free;                   ///< (N) reachable (painted free) or occluded
  double edge = 0.0;           ///< the target edge length h used, metres
};

/// Re-tessellates `mesh` into unit facets of edge length about `edge` (metres).
/// `free_faces` is a per-face mask of the mesh (empty: all free); each facet inherits the mask
/// of its source face. The facet areas have a coefficient of variation <= 0.3 on any mesh whose
/// features are not much smaller than `edge`. Throws std::invalid_argument for a non-positive
/// or non-finite edge, a mask of the wrong size, or an edge so small the result would exceed
/// `max_facets` (the message names the smallest edge that fits).
UnitFacets tessellate(const Mesh& mesh, double edge, const Mask& free_faces = Mask(),
                      long max_facets = 2'000'000);

}  // namespace pairgrasp
