// SurfaceQuery: AABB tree over a mesh's faces; closest point, signed distance, inside test, rays.
#include <pairgrasp/surface_query.hpp>

#include "surface_query_internal.hpp"

#include <pairgrasp/error.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

namespace pairgrasp {

using geometry_detail::Bvh;
using geometry_detail::BvhNode;
using geometry_detail::Vec3;
namespace vd = geometry_detail;

namespace {

constexpr int kStackSize = 128;  // tree depth is about log2(F / 4) + 1, far below this

std::string vec_str(const Vec3& p) {
  return "(" + std::to_string(p.x()) + ", " + std::to_string(p.y()) + ", " + std::to_string(p.z()) + ")";
}

void check_finite(const char* what, const Vec3& p) {
  if (!p.allFinite()) throw std::invalid_argument(std::string(what) + ": not finite " + vec_str(p));
}

// Fixed, well-spread, non-axis directions for the parity votes.
const std::array<Vec3, 7>& parity_directions() {
  static const std::array<Vec3, 7> dirs = [] {
    std::array<Vec3, 7> d = {Vec3(0.5773, 0.5905, 0.5639), Vec3(-0.6101, 0.3327, -0.7192),
                             Vec3(0.2411, -0.8863, 0.3954), Vec3(-0.3529, -0.4167, 0.8378),
                             Vec3(0.8641, -0.1719, -0.4730), Vec3(-0.1303, 0.9514, 0.2791),
                             Vec3(0.4471, 0.2233, -0.8664)};
    for (auto& v : d) v.normalize();
    return d;
  }();
  return dirs;
}

// Slab test of the segment o + t d, t in [0, t_max], against a node box.
inline bool ray_box(const Vec3& o, const Vec3& d, const Vec3& inv, double t_max, const BvhNode& n) {
  double t0 = 0.0, t1 = t_max;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d[k]) < 1e-300) {
      if (o[k] < n.lo[k] || o[k] > n.hi[k]) return false;
      continue;
    }
    double a = (n.lo[k] - o[k]) * inv[k], b = (n.hi[k] - o[k]) * inv[k];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
    if (t0 > t1) return false;
  }
  return true;
}

inline double box_box_dist2(const BvhNode& n, const Eigen::AlignedBox3d& b) {
  double s = 0.0;
  for (int k = 0; k < 3; ++k) {
    double e = 0.0;
    if (b.max()[k] < n.lo[k]) e = n.lo[k] - b.max()[k];
    else if (b.min()[k] > n.hi[k]) e = b.min()[k] - n.hi[k];
    s += e * e;
  }
  return s;
}

}  // namespace

struct SurfaceQuery::Impl {
  Mesh mesh;
  Bvh bvh;
  std::vector<Vec3> ta, tb, tc;          // triangle corners in leaf order
  std::vector<Vec3> normals;             // unit face normals by face id
  std::vector<std::array<int, 3>> face_edges;  // edge ids of (a,b), (b,c), (c,a)
  std::vector<Vec3> edge_pn;             // edge pseudo-normals (sum of adjacent face normals)
  std::vector<Vec3> vertex_pn;           // angle-weighted vertex pseudo-normals
  std::vector<char> vertex_fan_ok;       // the vertex's faces form one fan
  double tol = 0.0;
  bool closed = false;
  // Throws when the mesh has no inside (what names the calling function).
  void require_closed(const char* what) const;

  explicit Impl(const Mesh& m);

  // Closest point with its feature; best distance bound max_d (exclusive).
  struct Hit {
    Vec3 point;
    int face = -1;
    int feature = 0;
    double d2 = 0.0;
  };
  Hit closest(const Vec3& p, double max_d) const;
  Vec3 pseudo_normal(const Hit& h, bool& reliable) const;
  int parity_inside(const Vec3& p) const;  // 1 inside, 0 outside, -1 undecided
  double signed_distance(const Vec3& p, Hit& h, double bound = std::numeric_limits<double>::infinity()) const;
  // Calls leaf_fn(leaf position) for the triangles of every leaf the segment [0, t_max] of the
  // ray meets; t_max is re-read at every node so a caller may shrink it. leaf_fn returns false
  // to stop.
  template <class F>
  void ray_visit(const Vec3& o, const Vec3& d, const double& t_max, F&& leaf_fn) const;
};

SurfaceQuery::Impl::Impl(const Mesh& m) : mesh(m) {
  const Eigen::Index F = mesh.faces.rows(), V = mesh.vertices.rows();
  if (F == 0) throw std::invalid_argument("mesh: '" + mesh.source + "' has no faces");
  if (!mesh.vertices.allFinite())
    throw std::invalid_argument("mesh: '" + mesh.source + "' has non-finite vertices");
  if (mesh.faces.minCoeff() < 0 || mesh.faces.maxCoeff() >= V)
    throw std::invalid_argument("mesh: '" + mesh.source + "' has a face index out of range");
  closed = mesh.closed;
  Eigen::AlignedBox3d bounds;
  for (Eigen::Index v = 0; v < V; ++v) bounds.extend(Vec3(mesh.vertices.row(v).transpose()));
  tol = std::max(1e-9 * bounds.diagonal().norm(), 1e-15);

  normals.resize(F);
  std::vector<Eigen::AlignedBox3d> boxes(F);
  for (Eigen::Index f = 0; f < F; ++f) {
    const Vec3 a = mesh.vertices.row(mesh.faces(f, 0)).transpose();
    const Vec3 b = mesh.vertices.row(mesh.faces(f, 1)).transpose();
    const Vec3 c = mesh.vertices.row(mesh.faces(f, 2)).transpose();
    const Vec3 n = (b - a).cross(c - a);
    if (!(n.norm() > 0.0))
      throw std::invalid_argument("mesh: '" + mesh.source + "' face " + std::to_string(f) + " is degenerate");
    normals[f] = n.normalized();
    boxes[f].extend(a);
    boxes[f].extend(b);
    boxes[f].extend(c);
  }
  bvh.build(boxes, 4);
  ta.resize(F);
  tb.resize(F);
  tc.resize(F);
  for (Eigen::Index i = 0; i < F; ++i) {
    const int f = bvh.order[i];
    ta[i] = mesh.vertices.row(mesh.faces(f, 0)).transpose();
    tb[i] = mesh.vertices.row(mesh.faces(f, 1)).transpose();
    tc[i] = mesh.vertices.row(mesh.faces(f, 2)).transpose();
  }

  // Edges: sort the 3F half-edges by their undirected key; equal keys are one edge.
  std::vector<std::pair<std::uint64_t, int>> half(3 * F);
  for (Eigen::Index f = 0; f < F; ++f)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t i = mesh.faces(f, k), j = mesh.faces(f, (k + 1) % 3);
      half[3 * f + k] = {(static_cast<std::uint64_t>(std::min(i, j)) << 32) | std::max(i, j),
                         static_cast<int>(3 * f + k)};
    }
  std::sort(half.begin(), half.end());
  face_edges.assign(F, {-1, -1, -1});
  std::vector<std::vector<int>> edge_faces;
  for (std::size_t h = 0; h < half.size(); ++h) {
    if (h == 0 || half[h].first != half[h - 1].first) {
      edge_pn.emplace_back(Vec3::Zero());
      edge_faces.emplace_back();
    }
    const int e = static_cast<int>(edge_pn.size()) - 1;
    const int f = half[h].second / 3, k = half[h].second % 3;
    face_edges[f][k] = e;
    edge_pn[e] += normals[f];
    edge_faces[e].push_back(f);
  }

  // Vertex pseudo-normals: incident face normals weighted by the face's angle at the vertex.
  vertex_pn.assign(V, Vec3::Zero());
  std::vector<std::vector<int>> vertex_faces(V);
  for (Eigen::Index f = 0; f < F; ++f)
    for (int k = 0; k < 3; ++k) {
      const int i = mesh.faces(f, k);
      const Vec3 p = mesh.vertices.row(i).transpose();
      const Vec3 u = (Vec3(mesh.vertices.row(mesh.faces(f, (k + 1) % 3)).transpose()) - p).normalized();
      const Vec3 w = (Vec3(mesh.vertices.row(mesh.faces(f, (k + 2) % 3)).transpose()) - p).normalized();
      const double angle = std::atan2(u.cross(w).norm(), u.dot(w));
      vertex_pn[i] += angle * normals[f];
      vertex_faces[i].push_back(static_cast<int>(f));
    }
  // A vertex is reliable when walking across its edges from one incident face visits all of them
  // (one closed fan); a vertex shared by two fans (pinched solids) falls back to ray parity.
  vertex_fan_ok.assign(V, 0);
  if (closed) {
    for (Eigen::Index v = 0; v < V; ++v) {
      const auto& fs = vertex_faces[v];
      if (fs.empty()) continue;
      int f = fs[0], visited = 0;
      bool ok = true;
      do {
        // In face f the edge leaving v is (v, next); the face across it continues the fan.
        int k = 0;
        while (k < 3 && mesh.faces(f, k) != v) ++k;
        if (k == 3) {
          ok = false;
          break;
        }
        const auto& across = edge_faces[face_edges[f][k]];
        if (across.size() != 2) {
          ok = false;
          break;
        }
        f = across[0] == f ? across[1] : across[0];
        ++visited;
        if (visited > static_cast<int>(fs.size())) {
          ok = false;
          break;
        }
      } while (f != fs[0]);
      vertex_fan_ok[v] = ok && visited == static_cast<int>(fs.size());
    }
  }
}

SurfaceQuery::Impl::Hit SurfaceQuery::Impl::closest(const Vec3& p, double max_d) const {
  Hit best;
  best.d2 = std::isfinite(max_d) ? max_d * max_d : std::numeric_limits<double>::infinity();
  std::int32_t stack[kStackSize];
  int top = 0;
  if (vd::box_dist2(p, bvh.nodes[0].lo, bvh.nodes[0].hi) >= best.d2) return best;
  stack[top++] = 0;
  while (top > 0) {
    const BvhNode& node = bvh.nodes[stack[--top]];
    if (vd::box_dist2(p, node.lo, node.hi) >= best.d2) continue;
    if (node.count > 0) {
      for (std::int32_t i = node.first; i < node.first + node.count; ++i) {
        int feature;
        const Vec3 c = vd::closest_on_triangle(p, ta[i], tb[i], tc[i], feature);
        const double d2 = (p - c).squaredNorm();
        if (d2 < best.d2) {
          best.d2 = d2;
          best.point = c;
          best.face = bvh.order[i];
          best.feature = feature;
        }
      }
      continue;
    }
    const std::int32_t l = node.first, r = node.first + 1;
    const double dl = vd::box_dist2(p, bvh.nodes[l].lo, bvh.nodes[l].hi);
    const double dr = vd::box_dist2(p, bvh.nodes[r].lo, bvh.nodes[r].hi);
    // Push the farther child first so that the nearer one is searched first.
    if (dl <= dr) {
      if (dr < best.d2) stack[top++] = r;
      if (dl < best.d2) stack[top++] = l;
    } else {
      if (dl < best.d2) stack[top++] = l;
      if (dr < best.d2) stack[top++] = r;
    }
  }
  return best;
}

Vec3 SurfaceQuery::Impl::pseudo_normal(const Hit& h, bool& reliable) const {
  reliable = true;
  const auto& f = mesh.faces;
  switch (h.feature) {
    case vd::kFace: return normals[h.face];
    case vd::kEdgeAB: return edge_pn[face_edges[h.face][0]];
    case vd::kEdgeBC: return edge_pn[face_edges[h.face][1]];
    case vd::kEdgeCA: return edge_pn[face_edges[h.face][2]];
    default: {
      const int v = f(h.face, h.feature - vd::kVertexA);
      reliable = vertex_fan_ok[v] != 0;
      return vertex_pn[v];
    }
  }
}

template <class F>
void SurfaceQuery::Impl::ray_visit(const Vec3& o, const Vec3& d, const double& t_max, F&& leaf_fn) const {
  const Vec3 inv(1.0 / d.x(), 1.0 / d.y(), 1.0 / d.z());
  std::int32_t stack[kStackSize];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const BvhNode& node = bvh.nodes[stack[--top]];
    if (!ray_box(o, d, inv, t_max, node)) continue;
    if (node.count > 0) {
      for (std::int32_t i = node.first; i < node.first + node.count; ++i)
        if (!leaf_fn(i)) return;
    } else {
      stack[top++] = node.first + 1;
      stack[top++] = node.first;
    }
  }
}

int SurfaceQuery::Impl::parity_inside(const Vec3& p) const {
  const double eps = 1e-9;
  int votes_in = 0, votes = 0;
  for (const Vec3& d : parity_directions()) {
    int crossings = 0;
    bool ambiguous = false;
    const double inf = std::numeric_limits<double>::infinity();
    ray_visit(p, d, inf, [&](std::int32_t i) {
      const Vec3 e1 = tb[i] - ta[i], e2 = tc[i] - ta[i];
      const Vec3 pvec = d.cross(e2);
      const double det = e1.dot(pvec);
      const double scale = e1.norm() * e2.norm();
      const Vec3 tvec = p - ta[i];
      if (std::abs(det) < 1e-9 * scale) {
        // Ray (nearly) in the face's plane: ambiguous only if it passes through the face.
        const Vec3 n = normals[bvh.order[i]];
        if (std::abs(tvec.dot(n)) <= 1e-9 * std::sqrt(scale)) {
          Vec3 c1, c2;
          const Vec3 far = p + d * 1e3 * (std::sqrt(scale) + (p - ta[i]).norm());
          if (vd::segment_segment_dist2(p, far, ta[i], tb[i], c1, c2) <= tol * tol ||
              vd::segment_segment_dist2(p, far, tb[i], tc[i], c1, c2) <= tol * tol ||
              vd::segment_segment_dist2(p, far, tc[i], ta[i], c1, c2) <= tol * tol)
            ambiguous = true;
        }
        return !ambiguous;
      }
      const double inv_det = 1.0 / det;
      const double u = tvec.dot(pvec) * inv_det;
      const Vec3 qvec = tvec.cross(e1);
      const double v = d.dot(qvec) * inv_det;
      const double t = e2.dot(qvec) * inv_det;
      const double w = 1.0 - u - v;
      if (u < -eps || v < -eps || w < -eps || t < -tol) return true;  // clear miss
      if (u < eps || v < eps || w < eps || t <= tol) {
        ambiguous = true;  // through an edge or a vertex, or starting on the face
        return false;
      }
      ++crossings;
      return true;
    });
    if (ambiguous) continue;
    ++votes;
    votes_in += crossings % 2;
    if (votes == 3) break;
  }
  if (votes == 0) return -1;
  return 2 * votes_in > votes ? 1 : 0;
}

double SurfaceQuery::Impl::signed_distance(const Vec3& p, Hit& h, double bound) const {
  h = closest(p, std::isfinite(bound) ? bound * (1.0 + 1e-12) + tol : bound);
  if (h.face < 0) h = closest(p, std::numeric_limits<double>::infinity());
  const double d = std::sqrt(h.d2);
  if (d <= tol) return 0.0;
  bool reliable = true;
  const Vec3 n = pseudo_normal(h, reliable);
  const double dot = (p - h.point).dot(n);
  const double nn = n.norm();
  if (reliable && nn > 0.0 && std::abs(dot) > 1e-6 * d * nn) return dot > 0.0 ? d : -d;
  const int in = parity_inside(p);
  if (in >= 0) return in ? -d : d;
  return dot > 0.0 ? d : -d;  // every parity ray grazed an edge: keep the pseudo-normal's word
}

// ---------------------------------------------------------------- public

SurfaceQuery::SurfaceQuery(const Mesh& mesh) : impl_(std::make_shared<const Impl>(mesh)) {}

const Mesh& SurfaceQuery::mesh() const { return impl_->mesh; }
bool SurfaceQuery::closed() const { return impl_->closed; }
double SurfaceQuery::surface_tolerance() const { return impl_->tol; }
int SurfaceQuery::node_count() const { return static_cast<int>(impl_->bvh.nodes.size()); }

SurfacePoint SurfaceQuery::closest(const Eigen::Vector3d& p, double max_distance) const {
  check_finite("p", p);
  if (std::isnan(max_distance) || max_distance < 0.0)
    throw std::invalid_argument("max_distance: expected a non-negative length (m), got " +
                                std::to_string(max_distance));
  const auto h = impl_->closest(p, max_distance);
  SurfacePoint out;
  if (h.face < 0) return out;
  out.point = h.point;
  out.face = h.face;
  out.normal = impl_->normals[h.face];
  out.distance = std::sqrt(h.d2);
  return out;
}

double SurfaceQuery::distance(const Eigen::Vector3d& p) const { return closest(p).distance; }

void SurfaceQuery::Impl::require_closed(const char* what) const {
  if (!closed)
    throw std::invalid_argument(std::string(what) + ": mesh '" + mesh.source +
                                "' is not closed, so it has no inside");
}

bool SurfaceQuery::inside(const Eigen::Vector3d& p) const {
  impl_->require_closed("inside");
  check_finite("p", p);
  Impl::Hit h;
  return impl_->signed_distance(p, h) <= 0.0;
}

double SurfaceQuery::signed_distance(const Eigen::Vector3d& p) const {
  SurfacePoint cp;
  return signed_distance(p, cp);
}

double SurfaceQuery::signed_distance(const Eigen::Vector3d& p, SurfacePoint& cp) const {
  impl_->require_closed("signed_distance");
  check_finite("p", p);
  Impl::Hit h;
  const double sd = impl_->signed_distance(p, h);
  cp.point = h.point;
  cp.face = h.face;
  cp.normal = impl_->normals[h.face];
  cp.distance = std::sqrt(h.d2);
  return sd;
}

double SurfaceQuery::signed_distance_hint(const Eigen::Vector3d& p, double distance_bound) const {
  impl_->require_closed("signed_distance");
  check_finite("p", p);
  Impl::Hit h;
  return impl_->signed_distance(p, h, std::isnan(distance_bound) ? std::numeric_limits<double>::infinity()
                                                                  : std::max(distance_bound, 0.0));
}

static Vec3 checked_direction(const Vec3& origin, const Vec3& direction, double max_t) {
  check_finite("origin", origin);
  check_finite("direction", direction);
  const double n = direction.norm();
  if (!(n > 0.0)) throw std::invalid_argument("direction: must be non-zero");
  if (std::isnan(max_t) || max_t < 0.0)
    throw std::invalid_argument("max_t: expected a non-negative length (m), got " + std::to_string(max_t));
  return direction / n;
}

std::optional<RayHit> SurfaceQuery::ray_cast(const Eigen::Vector3d& origin,
                                             const Eigen::Vector3d& direction, double max_t) const {
  const Vec3 d = checked_direction(origin, direction, max_t);
  const Impl& I = *impl_;
  double best_t = max_t;
  int best = -1;
  I.ray_visit(origin, d, best_t, [&](std::int32_t i) {
    double t, u, v, det_rel;
    if (vd::ray_triangle(origin, d, I.ta[i], I.tb[i], I.tc[i], 0.0, best_t, t, u, v, det_rel)) {
      if (best < 0 || t < best_t || (t == best_t && I.bvh.order[i] < I.bvh.order[best])) {
        best_t = t;
        best = i;
      }
    }
    return true;
  });
  if (best < 0) return std::nullopt;
  RayHit hit;
  hit.t = best_t;
  hit.point = origin + d * best_t;
  hit.face = I.bvh.order[best];
  hit.normal = I.normals[hit.face];
  return hit;
}

std::vector<RayHit> SurfaceQuery::ray_hits(const Eigen::Vector3d& origin,
                                           const Eigen::Vector3d& direction, double max_t) const {
  const Vec3 d = checked_direction(origin, direction, max_t);
  const Impl& I = *impl_;
  std::vector<RayHit> hits;
  I.ray_visit(origin, d, max_t, [&](std::int32_t i) {
    double t, u, v, det_rel;
    if (vd::ray_triangle(origin, d, I.ta[i], I.tb[i], I.tc[i], 0.0, max_t, t, u, v, det_rel)) {
      RayHit hit;
      hit.t = t;
      hit.point = origin + d * t;
      hit.face = I.bvh.order[i];
      hit.normal = I.normals[hit.face];
      hits.push_back(hit);
    }
    return true;
  });
  std::sort(hits.begin(), hits.end(), [](const RayHit& a, const RayHit& b) {
    return a.t < b.t || (a.t == b.t && a.face < b.face);
  });
  return hits;
}

bool SurfaceQuery::ray_blocked(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                               double max_t, int ignore_face) const {
  const Vec3 d = checked_direction(origin, direction, max_t);
  const Impl& I = *impl_;
  bool blocked = false;
  I.ray_visit(origin, d, max_t, [&](std::int32_t i) {
    if (I.bvh.order[i] == ignore_face) return true;
    double t, u, v, det_rel;
    if (vd::ray_triangle(origin, d, I.ta[i], I.tb[i], I.tc[i], 0.0, max_t, t, u, v, det_rel)) {
      blocked = true;
      return false;
    }
    return true;
  });
  return blocked;
}

double SurfaceQuery::triangle_distance(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c, double max_distance) const {
  check_finite("a", a);
  check_finite("b", b);
  check_finite("c", c);
  const Impl& I = *impl_;
  Eigen::AlignedBox3d box;
  box.extend(a);
  box.extend(b);
  box.extend(c);
  double best = max_distance;
  const double best0 = max_distance;
  std::int32_t stack[kStackSize];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const BvhNode& node = I.bvh.nodes[stack[--top]];
    const double bd2 = box_box_dist2(node, box);
    if (std::isfinite(best) ? bd2 >= best * best : false) continue;
    if (node.count > 0) {
      for (std::int32_t i = node.first; i < node.first + node.count; ++i) {
        const double d = vd::triangle_triangle_distance(a, b, c, I.ta[i], I.tb[i], I.tc[i]);
        if (d < best) best = d;
        if (best == 0.0) return 0.0;
      }
    } else {
      stack[top++] = node.first + 1;
      stack[top++] = node.first;
    }
  }
  return best < best0 ? best : std::numeric_limits<double>::infinity();
}

// ---------------------------------------------------------------- batches

static void check_rows_finite(const char* what, const Points& p) {
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    if (!p.row(i).allFinite())
      throw std::invalid_argument(std::string(what) + ": row " + std::to_string(i) + " is not finite");
}

SurfacePoints SurfaceQuery::batch_closest(const Points& points, int threads) const {
  check_rows_finite("points", points);
  const Eigen::Index n = points.rows();
  SurfacePoints out;
  out.points.resize(n, 3);
  out.normals.resize(n, 3);
  out.faces.resize(n);
  out.distances.resize(n);
  const Impl& I = *impl_;
  vd::parallel_for(n, threads, [&](std::size_t i) {
    const auto h = I.closest(points.row(i).transpose(), std::numeric_limits<double>::infinity());
    out.points.row(i) = h.point.transpose();
    out.normals.row(i) = I.normals[h.face].transpose();
    out.faces[i] = h.face;
    out.distances[i] = std::sqrt(h.d2);
  });
  return out;
}

Eigen::VectorXd SurfaceQuery::batch_distance(const Points& points, int threads) const {
  return batch_closest(points, threads).distances;
}

Eigen::VectorXd SurfaceQuery::batch_signed_distance(const Points& points, int threads) const {
  impl_->require_closed("signed_distance");
  check_rows_finite("points", points);
  Eigen::VectorXd out(points.rows());
  const Impl& I = *impl_;
  vd::parallel_for(points.rows(), threads, [&](std::size_t i) {
    Impl::Hit h;
    out[i] = I.signed_distance(points.row(i).transpose(), h);
  });
  return out;
}

Mask SurfaceQuery::batch_inside(const Points& points, int threads) const {
  impl_->require_closed("inside");
  const Eigen::VectorXd sd = batch_signed_distance(points, threads);
  return (sd.array() <= 0.0).matrix();
}

RayHits SurfaceQuery::batch_ray_cast(const Points& origins, const Points& directions, int threads,
                               double max_t) const {
  detail::check_size("directions: rows", origins.rows(), directions.rows());
  check_rows_finite("origins", origins);
  check_rows_finite("directions", directions);
  for (Eigen::Index i = 0; i < directions.rows(); ++i)
    if (!(directions.row(i).norm() > 0.0))
      throw std::invalid_argument("directions: row " + std::to_string(i) + " is zero");
  const Eigen::Index n = origins.rows();
  RayHits out;
  out.t = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::infinity());
  out.points = Points::Zero(n, 3);
  out.normals = Points::Zero(n, 3);
  out.faces = Eigen::VectorXi::Constant(n, -1);
  vd::parallel_for(n, threads, [&](std::size_t i) {
    const auto hit = ray_cast(origins.row(i).transpose(), directions.row(i).transpose(), max_t);
    if (!hit) return;
    out.t[i] = hit->t;
    out.points.row(i) = hit->point.transpose();
    out.normals.row(i) = hit->normal.transpose();
    out.faces[i] = hit->face;
  });
  return out;
}

}  // namespace pairgrasp
