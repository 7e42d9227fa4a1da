#pragma once
// Internal geometry of surface queries and collision: triangle/segment primitives, a flat AABB tree
// builder, surface sampling and a deterministic parallel loop. Not part of the public API.
#include <pairgrasp/types.hpp>

#include "thread_pool.hpp"

#include <Eigen/Geometry>

#include <cstdint>
#include <functional>
#include <vector>

namespace pairgrasp::geometry_detail {

using Vec3 = Eigen::Vector3d;

// ------------------------------------------------------------------ primitives

/// Which feature of a triangle (a, b, c) holds a closest point.
enum TriFeature : int {
  kFace = 0,
  kVertexA = 1, kVertexB = 2, kVertexC = 3,
  kEdgeAB = 4, kEdgeBC = 5, kEdgeCA = 6,
};

/// Closest point of triangle (a, b, c) to p, and the feature holding it (Ericson, Real-Time
/// Collision Detection, 5.1.5). The triangle must not be degenerate.
Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, int& feature);
/// Closest point of triangle (a, b, c) to p.
inline Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  int feature = kFace;
  return closest_on_triangle(p, a, b, c, feature);
}

/// Squared distance between segments [p1,q1] and [p2,q2]; c1, c2 receive the closest points.
double segment_segment_dist2(const Vec3& p1, const Vec3& q1, const Vec3& p2, const Vec3& q2,
                             Vec3& c1, Vec3& c2);

/// Ray/segment against triangle (Möller–Trumbore, both sides). On a hit within [t_min, t_max]
/// returns true with t and the barycentric (u, v) of the hit (w = 1 - u - v belongs to a).
/// `det_rel` receives |det| / (|e1||e2||dir|), small when the ray grazes the triangle's plane.
bool ray_triangle(const Vec3& o, const Vec3& d, const Vec3& a, const Vec3& b, const Vec3& c,
                  double t_min, double t_max, double& t, double& u, double& v, double& det_rel);

/// Whether triangles (a0,a1,a2) and (b0,b1,b2) intersect (touching included, up to rounding).
bool triangles_intersect(const Vec3& a0, const Vec3& a1, const Vec3& a2, const Vec3& b0,
                         const Vec3& b1, const Vec3& b2);

/// Smallest distance between two triangles (0 when they intersect).
double triangle_triangle_distance(const Vec3& a0, const Vec3& a1, const Vec3& a2, const Vec3& b0,
                                  const Vec3& b1, const Vec3& b2);

/// Squared distance from p to the box (0 inside).
inline double box_dist2(const Vec3& p, const double* lo, const double* hi) {
  double s = 0.0;
  for (int k = 0; k < 3; ++k) {
    double e = 0.0;
    if (p[k] < lo[k]) e = lo[k] - p[k];
    else if (p[k] > hi[k]) e = p[k] - hi[k];
    s += e * e;
  }
  return s;
}

// ------------------------------------------------------------------ tree

/// A node of a flat AABB tree. Leaves hold `count` > 0 primitives starting at `first` in the
/// tree's `order`; internal nodes (count == 0) have children `first` and `first + 1`.
struct BvhNode {
  double lo[3];
  double hi[3];
  std::int32_t first = 0;
  std::int32_t count = 0;
};

/// A balanced AABB tree over primitives given by their boxes (median split of the centroids
/// along the longest axis), built in O(N log N).
struct Bvh {
  std::vector<BvhNode> nodes;      ///< nodes[0] is the root (when not empty)
  std::vector<std::int32_t> order; ///< primitive ids in leaf order

  /// Builds over boxes lo/hi (N rows each). leaf_size >= 1.
  void build(const std::vector<Eigen::AlignedBox3d>& boxes, int leaf_size = 4);
  bool empty() const { return nodes.empty(); }
  /// Calls visit(primitive id) for every primitive whose box overlaps `box`.
  void overlapping(const Eigen::AlignedBox3d& box, const std::function<void(int)>& visit) const;
};

// ------------------------------------------------------------------ sampling

/// Points covering the given faces so that every surface point lies within about `spacing`
/// of a sample (at most 1.5 spacing): the faces' vertices, points along each edge at <= spacing
/// and, inside each face, a square lattice of pitch `spacing` aligned with its longest edge and
/// kept a quarter pitch from the edges (about area / spacing^2 points, however thin the face).
/// Each vertex and edge sample is listed once. `faces_subset` empty = all faces. `face_of` receives a face holding each sample.
/// Throws std::invalid_argument when more than `max_samples` would be made.
Points sample_surface(const Points& vertices, const Triangles& faces,
                      const std::vector<int>& faces_subset, double spacing,
                      std::vector<int>* face_of = nullptr, std::size_t max_samples = 20'000'000);

/// Connected components of a mesh's faces through shared vertices: returns the component id of
/// every vertex (-1 for unused vertices) and sets `count`.
std::vector<int> vertex_components(const Points& vertices, const Triangles& faces, int& count);

// ------------------------------------------------------------------ threads

/// Parallel loops run on the library's one pool (thread_pool.hpp).
using detail::parallel_for;  // the shared pool (thread_pool.hpp)

}  // namespace pairgrasp::geometry_detail
