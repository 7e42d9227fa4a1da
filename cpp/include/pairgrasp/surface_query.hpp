#pragma once
/// @file surface_query.hpp
/// Geometric queries against a triangle mesh through a flat, balanced AABB tree over its faces:
/// closest point, unsigned / signed distance, inside test, ray casts.
///
/// Built once per mesh in O(F log F); every query is const and thread-safe (no shared scratch),
/// so many threads may query one SurfaceQuery at once. Lengths are metres.
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/types.hpp>

#include <limits>
#include <memory>
#include <optional>
#include <vector>

namespace pairgrasp {

/// The point of a surface closest to a query point.
struct SurfacePoint {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< closest point on the surface, metres
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< unit outward normal of `face`
  int face = -1;          ///< face holding the closest point; -1 when none lies within the bound
  double distance = std::numeric_limits<double>::infinity();  ///< |query - point|, metres
};

/// Closest points of a batch of query points, row k for query point k.
struct SurfacePoints {
  Points points;               ///< (N,3) closest points, metres
  Points normals;              ///< (N,3) unit outward normals of the faces holding them
  Eigen::VectorXi faces;       ///< (N) face ids
  Eigen::VectorXd distances;   ///< (N) unsigned distances, metres
};

/// Where a ray meets a face.
struct RayHit {
  double t = 0.0;        ///< distance from the origin along the (normalised) direction, metres
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< hit point, metres
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< unit outward normal of `face`
  int face = -1;         ///< face hit
};

/// First hits of a batch of rays, row k for ray k. Rays that hit nothing have face -1, t = inf
/// and a zero point and normal.
struct RayHits {
  Eigen::VectorXd t;       ///< (N) metres along the normalised direction (inf: no hit)
  Points points;           ///< (N,3) hit points
  Points normals;          ///< (N,3) unit outward normals of the faces hit
  Eigen::VectorXi faces;   ///< (N) faces hit, -1 for none
};

/// Closest points, distances, inside tests and ray casts on one mesh.
///
/// **Inside test** (closed meshes only). The sign comes from the angle-weighted pseudo-normal
/// of the surface feature (face, edge or vertex) holding the closest point: for a closed,
/// consistently wound mesh, p is outside exactly when (p - closest)·pseudo_normal > 0
/// (Bærentzen & Aanæs, 2005). Where that test is ill-conditioned (p - closest nearly tangent,
/// or the closest point at a vertex whose faces do not form one fan) the answer is the majority
/// of up to three ray-parity counts along fixed, non-axis directions, each ray re-cast in another
/// direction when it grazes an edge or a vertex. Points within `surface_tolerance()` of the
/// surface are **on** it: inside() is true for them and signed_distance() returns 0.
/// Mesh inner walls (a hollow solid's cavity, normals into the cavity) are handled by the same
/// rule: points in the cavity are outside.
class SurfaceQuery {
 public:
  /// Builds the tree over a copy of `mesh` (validated as make_mesh()/load_mesh() return it).
  /// Throws std::invalid_argument("mesh: ...") for a mesh with no faces or invalid indices.
  explicit SurfaceQuery(const Mesh& mesh);

  /// The mesh queried (the copy held).
  const Mesh& mesh() const;
  /// Whether the mesh is closed, so that inside() and signed_distance() are defined.
  bool closed() const;
  /// Distance below which a point counts as on the surface: 1e-9 of the bounding-box diagonal.
  double surface_tolerance() const;
  /// Number of tree nodes (for reports).
  int node_count() const;

  /// Closest point of the surface to p. With `max_distance`, only points strictly closer than
  /// it are looked for (faster); if there is none the result has face -1 and distance inf.
  /// Throws std::invalid_argument for a non-finite p.
  SurfacePoint closest(const Eigen::Vector3d& p,
                       double max_distance = std::numeric_limits<double>::infinity()) const;
  /// Unsigned distance from p to the surface, metres.
  double distance(const Eigen::Vector3d& p) const;
  /// Whether p lies inside the solid (surface included). Throws std::invalid_argument when the
  /// mesh is not closed or p is not finite.
  bool inside(const Eigen::Vector3d& p) const;
  /// Signed distance to the surface, metres: negative inside, positive outside, 0 on it.
  /// Throws std::invalid_argument when the mesh is not closed or p is not finite.
  double signed_distance(const Eigen::Vector3d& p) const;
  /// Signed distance and the closest point in one query (the closest point's `distance` is
  /// unsigned). Throws as signed_distance().
  double signed_distance(const Eigen::Vector3d& p, SurfacePoint& closest_point) const;
  /// signed_distance() given an upper bound on the unsigned distance (metres), e.g. a nearby
  /// point's distance plus the separation (distance is 1-Lipschitz): the search is limited to
  /// it, which is much faster for points deep inside. A bound that turns out too small only
  /// costs a second, unbounded search. Throws as signed_distance().
  double signed_distance_hint(const Eigen::Vector3d& p, double distance_bound) const;

  /// First face hit by the ray origin + t·direction/|direction|, 0 <= t <= max_t (metres).
  /// Both sides of a face count. Throws std::invalid_argument for a zero or non-finite
  /// direction, a non-finite origin or a negative max_t.
  std::optional<RayHit> ray_cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                 double max_t = std::numeric_limits<double>::infinity()) const;
  /// Every face hit by the ray within [0, max_t], sorted by t. Throws as ray_cast().
  std::vector<RayHit> ray_hits(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                               double max_t = std::numeric_limits<double>::infinity()) const;
  /// Whether any face is hit within [0, max_t] other than `ignore_face` (shadow rays).
  bool ray_blocked(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double max_t,
                   int ignore_face = -1) const;

  /// Smallest distance (metres) between the triangle (a, b, c) and the surface, 0 when they
  /// intersect; only distances below `max_distance` are resolved (a larger one returns inf).
  double triangle_distance(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                           const Eigen::Vector3d& c,
                           double max_distance = std::numeric_limits<double>::infinity()) const;

  // ---------------------------------------------------------------- batches
  // Each takes (N,3) points; `threads` 0 = all cores, results do not depend on it. (Named
  // batch_* so that Eigen expressions never make an overload ambiguous.)

  /// closest() for every row. Throws std::invalid_argument("points: ...") for non-finite rows.
  SurfacePoints batch_closest(const Points& points, int threads = 0) const;
  /// distance() for every row.
  Eigen::VectorXd batch_distance(const Points& points, int threads = 0) const;
  /// inside() for every row.
  Mask batch_inside(const Points& points, int threads = 0) const;
  /// signed_distance() for every row.
  Eigen::VectorXd batch_signed_distance(const Points& points, int threads = 0) const;
  /// ray_cast() for every row of origins and directions (same row count).
  RayHits batch_ray_cast(const Points& origins, const Points& directions, int threads = 0,
                   double max_t = std::numeric_limits<double>::infinity()) const;

 private:
  struct Impl;  // defined in the library's sources
  std::shared_ptr<const Impl> impl_;
};

}  // namespace pairgrasp
