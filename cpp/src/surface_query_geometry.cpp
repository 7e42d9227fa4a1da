// Geometric primitives, the flat AABB tree builder and surface sampling of
// the surface queries, the free surface, collision, closing and contacts.
#include "surface_query_internal.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <mutex>
#include <numeric>
#include <stdexcept>
#include <string>
#include <thread>

namespace pairgrasp::geometry_detail {

Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, int& feature) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) {
    feature = kVertexA;
    return a;
  }
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) {
    feature = kVertexB;
    return b;
  }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    feature = kEdgeAB;
    return a + (d1 / (d1 - d3)) * ab;
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) {
    feature = kVertexC;
    return c;
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    feature = kEdgeCA;
    return a + (d2 / (d2 - d6)) * ac;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    feature = kEdgeBC;
    return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  }
  const double denom = 1.0 / (va + vb + vc);
  feature = kFace;
  return a + ab * (vb * denom) + ac * (vc * denom);
}

static double clamp01(double x) { return x < 0.0 ? 0.0 : (x > 1.0 ? 1.0 : x); }

double segment_segment_dist2(const Vec3& p1, const Vec3& q1, const Vec3& p2, const Vec3& q2,
                             Vec3& c1, Vec3& c2) {
  const Vec3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  const double tiny = 1e-300;
  double s = 0.0, t = 0.0;
  if (a <= tiny && e <= tiny) {
    s = t = 0.0;
  } else if (a <= tiny) {
    s = 0.0;
    t = clamp01(f / e);
  } else {
    const double c = d1.dot(r);
    if (e <= tiny) {
      t = 0.0;
      s = clamp01(-c / a);
    } else {
      const double b = d1.dot(d2);
      const double denom = a * e - b * b;
      s = denom > 1e-14 * a * e ? clamp01((b * f - c * e) / denom) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = clamp01(-c / a);
      } else if (t > 1.0) {
        t = 1.0;
        s = clamp01((b - c) / a);
      }
    }
  }
  c1 = p1 + d1 * s;
  c2 = p2 + d2 * t;
  return (c1 - c2).squaredNorm();
}

bool ray_triangle(const Vec3& o, const Vec3& d, const Vec3& a, const Vec3& b, const Vec3& c,
                  double t_min, double t_max, double& t, double& u, double& v, double& det_rel) {
  const Vec3 e1 = b - a, e2 = c - a;
  const Vec3 pvec = d.cross(e2);
  const double det = e1.dot(pvec);
  const double scale = e1.norm() * e2.norm() * d.norm();
  det_rel = scale > 0.0 ? std::abs(det) / scale : 0.0;
  if (det_rel < 1e-12) return false;  // ray in (or numerically in) the triangle's plane
  const double inv = 1.0 / det;
  const Vec3 tvec = o - a;
  u = tvec.dot(pvec) * inv;
  if (u < 0.0 || u > 1.0) return false;
  const Vec3 qvec = tvec.cross(e1);
  v = d.dot(qvec) * inv;
  if (v < 0.0 || u + v > 1.0) return false;
  t = e2.dot(qvec) * inv;
  return t >= t_min && t <= t_max;
}

static bool segment_hits_triangle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b,
                                  const Vec3& c) {
  double t, u, v, det_rel;
  return ray_triangle(p, q - p, a, b, c, 0.0, 1.0, t, u, v, det_rel);
}

double triangle_triangle_distance(const Vec3& a0, const Vec3& a1, const Vec3& a2, const Vec3& b0,
                                  const Vec3& b1, const Vec3& b2) {
  const Vec3* A[3] = {&a0, &a1, &a2};
  const Vec3* B[3] = {&b0, &b1, &b2};
  // A crossing: an edge of one triangle passes through the other (non-coplanar case).
  for (int i = 0; i < 3; ++i) {
    if (segment_hits_triangle(*A[i], *A[(i + 1) % 3], b0, b1, b2)) return 0.0;
    if (segment_hits_triangle(*B[i], *B[(i + 1) % 3], a0, a1, a2)) return 0.0;
  }
  // Otherwise the closest pair involves a vertex and a face or two edges (coplanar overlaps
  // give 0 here too: a vertex inside the other triangle or two crossing edges).
  double best = std::numeric_limits<double>::infinity();
  int feature;
  for (int i = 0; i < 3; ++i) {
    best = std::min(best, (closest_on_triangle(*A[i], b0, b1, b2, feature) - *A[i]).squaredNorm());
    best = std::min(best, (closest_on_triangle(*B[i], a0, a1, a2, feature) - *B[i]).squaredNorm());
  }
  Vec3 c1, c2;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      best = std::min(best, segment_segment_dist2(*A[i], *A[(i + 1) % 3], *B[j], *B[(j + 1) % 3], c1, c2));
  return std::sqrt(best);
}

bool triangles_intersect(const Vec3& a0, const Vec3& a1, const Vec3& a2, const Vec3& b0,
                         const Vec3& b1, const Vec3& b2) {
  const double scale = std::max({(a1 - a0).norm(), (a2 - a0).norm(), (b1 - b0).norm(), (b2 - b0).norm()});
  return triangle_triangle_distance(a0, a1, a2, b0, b1, b2) <= 1e-12 * scale;
}

// ------------------------------------------------------------------ tree

void Bvh::build(const std::vector<Eigen::AlignedBox3d>& boxes, int leaf_size) {
  const std::int32_t n = static_cast<std::int32_t>(boxes.size());
  nodes.clear();
  order.resize(n);
  std::iota(order.begin(), order.end(), 0);
  if (n == 0) return;
  if (leaf_size < 1) leaf_size = 1;
  std::vector<Vec3> centroid(n);
  for (std::int32_t i = 0; i < n; ++i) centroid[i] = boxes[i].center();
  nodes.reserve(2 * (n / leaf_size + 1));
  nodes.emplace_back();
  struct Task {
    std::int32_t node, begin, end;
  };
  std::vector<Task> stack{{0, 0, n}};
  while (!stack.empty()) {
    const Task task = stack.back();
    stack.pop_back();
    Eigen::AlignedBox3d box;
    Eigen::AlignedBox3d cbox;
    for (std::int32_t i = task.begin; i < task.end; ++i) {
      box.extend(boxes[order[i]]);
      cbox.extend(centroid[order[i]]);
    }
    BvhNode& node = nodes[task.node];
    for (int k = 0; k < 3; ++k) {
      node.lo[k] = box.min()[k];
      node.hi[k] = box.max()[k];
    }
    if (task.end - task.begin <= leaf_size) {
      node.first = task.begin;
      node.count = task.end - task.begin;
      continue;
    }
    int axis = 0;
    cbox.sizes().maxCoeff(&axis);
    const std::int32_t mid = task.begin + (task.end - task.begin) / 2;
    std::nth_element(order.begin() + task.begin, order.begin() + mid, order.begin() + task.end,
                     [&](std::int32_t x, std::int32_t y) {
                       const double cx = centroid[x][axis], cy = centroid[y][axis];
                       return cx < cy || (cx == cy && x < y);
                     });
    const std::int32_t left = static_cast<std::int32_t>(nodes.size());
    nodes[task.node].first = left;
    nodes[task.node].count = 0;
    nodes.emplace_back();
    nodes.emplace_back();
    stack.push_back({left + 1, mid, task.end});
    stack.push_back({left, task.begin, mid});
  }
}

void Bvh::overlapping(const Eigen::AlignedBox3d& box, const std::function<void(int)>& visit) const {
  if (nodes.empty() || box.isEmpty()) return;
  std::int32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const BvhNode& node = nodes[stack[--top]];
    bool overlap = true;
    for (int k = 0; k < 3; ++k)
      if (node.lo[k] > box.max()[k] || node.hi[k] < box.min()[k]) overlap = false;
    if (!overlap) continue;
    if (node.count > 0) {
      for (std::int32_t i = node.first; i < node.first + node.count; ++i) visit(order[i]);
    } else {
      stack[top++] = node.first + 1;
      stack[top++] = node.first;
    }
  }
}

// ------------------------------------------------------------------ sampling

Points sample_surface(const Points& vertices, const Triangles& faces,
                      const std::vector<int>& faces_subset, double spacing,
                      std::vector<int>* face_of, std::size_t max_samples) {
  if (!(spacing > 0.0) || !std::isfinite(spacing))
    throw std::invalid_argument("spacing: expected a positive finite length (m), got " +
                                std::to_string(spacing));
  std::vector<int> subset = faces_subset;
  if (subset.empty()) {
    subset.resize(faces.rows());
    std::iota(subset.begin(), subset.end(), 0);
  }
  std::vector<Vec3> out;
  std::vector<int> owner;
  auto count_check = [&](std::size_t more) {
    if (out.size() + more > max_samples)
      throw std::invalid_argument("spacing: " + std::to_string(spacing) +
                                  " m would make more than " + std::to_string(max_samples) +
                                  " surface samples; use a larger spacing");
  };
  // Vertices (each once) and edges (each once, keyed by their sorted vertex pair).
  std::vector<int> vertex_face(vertices.rows(), -1);
  std::vector<std::uint64_t> edges;
  std::vector<int> edge_face;
  edges.reserve(subset.size() * 3);
  for (int f : subset) {
    for (int k = 0; k < 3; ++k) {
      const int i = faces(f, k), j = faces(f, (k + 1) % 3);
      if (vertex_face[i] < 0) vertex_face[i] = f;
      const std::uint64_t key = (static_cast<std::uint64_t>(std::min(i, j)) << 32) |
                                static_cast<std::uint32_t>(std::max(i, j));
      edges.push_back(key);
    }
  }
  std::vector<std::size_t> edge_order(edges.size());
  std::iota(edge_order.begin(), edge_order.end(), 0);
  std::stable_sort(edge_order.begin(), edge_order.end(),
                   [&](std::size_t x, std::size_t y) { return edges[x] < edges[y]; });
  for (Eigen::Index v = 0; v < vertices.rows(); ++v)
    if (vertex_face[v] >= 0) {
      out.emplace_back(vertices.row(v).transpose());
      owner.push_back(vertex_face[v]);
    }
  for (std::size_t k = 0; k < edge_order.size(); ++k) {
    const std::size_t e = edge_order[k];
    if (k > 0 && edges[edge_order[k - 1]] == edges[e]) continue;
    const int i = static_cast<int>(edges[e] >> 32), j = static_cast<int>(edges[e] & 0xffffffffu);
    const Vec3 a = vertices.row(i).transpose(), b = vertices.row(j).transpose();
    const int m = static_cast<int>(std::ceil((b - a).norm() / spacing));
    if (m > 1) count_check(m - 1);
    for (int s = 1; s < m; ++s) {
      out.push_back(a + (b - a) * (static_cast<double>(s) / m));
      owner.push_back(subset[e / 3]);
    }
  }
  // Inside each face: a square lattice of pitch `spacing` in the face's plane, aligned with its
  // longest edge, kept a quarter pitch away from the edges (which have their own samples). So a
  // long thin face gets about area / spacing^2 samples, not (length / spacing)^2.
  const double margin = 0.25 * spacing;
  for (int f : subset) {
    Vec3 p[3];
    for (int k = 0; k < 3; ++k) p[k] = vertices.row(faces(f, k)).transpose();
    int longest = 0;
    double best = -1.0;
    for (int k = 0; k < 3; ++k) {
      const double l = (p[(k + 1) % 3] - p[k]).norm();
      if (l > best) best = l, longest = k;
    }
    const Vec3 a = p[longest], b = p[(longest + 1) % 3], c = p[(longest + 2) % 3];
    const double L = (b - a).norm();
    const Vec3 u = (b - a) / L;
    Vec3 w = (c - a) - u * (c - a).dot(u);
    const double H = w.norm();
    if (!(H > 2.0 * margin)) continue;  // thinner than the margins: its edges cover it
    w /= H;
    const double cx = (c - a).dot(u);
    const int rows = static_cast<int>(std::ceil((H - margin) / spacing));
    count_check(static_cast<std::size_t>(rows) * static_cast<std::size_t>(std::ceil(L / spacing) + 1));
    for (int j = 1; j < rows; ++j) {
      const double h = j * spacing;
      if (h > H - margin) break;
      // Cross-section at height h: between the edges a-c and b-c.
      const double x0 = cx * h / H, x1 = L + (cx - L) * h / H;
      const double lo = x0 + margin * (1.0 + std::abs(cx) / H), hi = x1 - margin * (1.0 + std::abs(L - cx) / H);
      for (int i = static_cast<int>(std::ceil(lo / spacing)); i * spacing <= hi; ++i) {
        out.push_back(a + u * (i * spacing) + w * h);
        owner.push_back(f);
      }
    }
  }
  Points result(static_cast<Eigen::Index>(out.size()), 3);
  for (std::size_t i = 0; i < out.size(); ++i) result.row(static_cast<Eigen::Index>(i)) = out[i].transpose();
  if (face_of) *face_of = std::move(owner);
  return result;
}

std::vector<int> vertex_components(const Points& vertices, const Triangles& faces, int& count) {
  std::vector<int> parent(vertices.rows());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::vector<char> used(vertices.rows(), 0);
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      used[faces(f, k)] = 1;
      const int a = find(faces(f, k)), b = find(faces(f, (k + 1) % 3));
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  std::vector<int> comp(vertices.rows(), -1), root_id(vertices.rows(), -1);
  count = 0;
  for (Eigen::Index v = 0; v < vertices.rows(); ++v) {
    if (!used[v]) continue;
    const int r = find(static_cast<int>(v));
    if (root_id[r] < 0) root_id[r] = count++;
    comp[v] = root_id[r];
  }
  return comp;
}

}  // namespace pairgrasp::geometry_detail
