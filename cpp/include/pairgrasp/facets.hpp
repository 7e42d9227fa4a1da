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

/// Re-tessellates `mesh` into unit facets about `edge` (h, metres) apart.
///
/// Method (a discrete, normal-aware centroidal Voronoi tessellation): each face is cut into
/// pieces by square cells of side h/4 in its plane; seeds are placed by random sequential
/// adsorption (fixed pseudo-random order) at radius 0.745 h, which leaves one seed per about
/// (sqrt(3)/2) h^2 -- the cell of a hexagonal lattice of spacing h, so a surface of area A gives
/// about A / (0.866 h^2) facets; up to 10 Lloyd iterations then move each seed to its cell's
/// centroid. A piece only joins a seed with the same paint whose normal is within 60 degrees, so
/// facets never span a sharp edge, a thin wall or a paint border, and a region cut off that way
/// (even a face much smaller than h) gets a facet of its own. A facet's area is the sum of its
/// pieces (the facet areas add up to the mesh area, to rounding); its centre is the surface point
/// nearest its cell's centroid, its normal, paint and face id those of the face holding the centre.
///
/// `free_faces` is a per-face mask of the mesh (empty: all free); each facet inherits the mask
/// of its source face. The facet areas have a coefficient of variation <= 0.3 on any mesh whose
/// features are not much smaller than `edge` (0.12-0.17 on boxes, cylinders with fan caps,
/// spheres and the bundled targets). Deterministic (same result on every run and thread count);
/// uses all cores. Memory: about 1.5 kB per facet while it runs.
/// Throws std::invalid_argument for a non-positive or non-finite edge, a mask of the wrong size,
/// a mesh without faces, with non-finite vertices or out-of-range indices, or an edge so small
/// the result would exceed `max_facets` (the message names the smallest edge that fits, found by
/// trying it).
UnitFacets tessellate(const Mesh& mesh, double edge, const Mask& free_faces = Mask(),
                      long max_facets = 2'000'000);

}  // namespace pairgrasp
