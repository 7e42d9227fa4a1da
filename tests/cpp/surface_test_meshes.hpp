#pragma once
// Test meshes for the surface tests, built from their dimensions (independent of the library).
#include <pairgrasp/mesh.hpp>

#include <cmath>
#include <map>
#include <vector>

namespace surface_test {

using pairgrasp::Mesh;
using pairgrasp::Points;
using pairgrasp::Triangles;

/// A mesh from vertex and triangle lists, validated by make_mesh (the arrays are already clean,
/// so faces keep their order).
inline Mesh from_arrays(const std::vector<Eigen::Vector3d>& v, const std::vector<Eigen::Vector3i>& f,
                        const char* name) {
  Points vertices(Eigen::Index(v.size()), 3);
  Triangles faces(Eigen::Index(f.size()), 3);
  for (std::size_t i = 0; i < v.size(); ++i) vertices.row(Eigen::Index(i)) = v[i].transpose();
  for (std::size_t i = 0; i < f.size(); ++i) faces.row(Eigen::Index(i)) = f[i].transpose();
  return pairgrasp::make_mesh(vertices, faces, name);
}

/// Axis-aligned box [0,a]x[0,b]x[0,c], two triangles per side, outward winding.
inline Mesh box(double a, double b, double c) {
  std::vector<Eigen::Vector3d> v;
  for (int k = 0; k < 8; ++k) v.emplace_back((k & 1) * a, ((k >> 1) & 1) * b, ((k >> 2) & 1) * c);
  // quads (counter-clockwise seen from outside)
  const int q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  std::vector<Eigen::Vector3i> f;
  for (auto& s : q) {
    f.emplace_back(s[0], s[1], s[2]);
    f.emplace_back(s[0], s[2], s[3]);
  }
  return from_arrays(v, f, "box");
}

/// Closed cylinder of radius r, height h along z, `seg` segments; each cap is a fan around its
/// centre (long thin triangles: the case plain edge splitting handles badly).
inline Mesh fan_cylinder(double r, double h, int seg) {
  std::vector<Eigen::Vector3d> v;
  for (int k = 0; k < seg; ++k) {
    const double t = 2 * M_PI * k / seg;
    v.emplace_back(r * std::cos(t), r * std::sin(t), 0.0);
    v.emplace_back(r * std::cos(t), r * std::sin(t), h);
  }
  const int bottom = int(v.size());
  v.emplace_back(0, 0, 0);
  const int top = int(v.size());
  v.emplace_back(0, 0, h);
  std::vector<Eigen::Vector3i> f;
  for (int k = 0; k < seg; ++k) {
    const int a0 = 2 * k, a1 = 2 * k + 1, b0 = 2 * ((k + 1) % seg), b1 = b0 + 1;
    f.emplace_back(a0, b0, b1);
    f.emplace_back(a0, b1, a1);
    f.emplace_back(bottom, b0, a0);
    f.emplace_back(top, a1, b1);
  }
  return from_arrays(v, f, "fan_cylinder");
}

/// Icosphere of radius r: an icosahedron subdivided `level` times, vertices pushed to the sphere.
inline Mesh icosphere(double r, int level) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                                    {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<Eigen::Vector3i> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                    {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                    {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                    {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (auto& p : v) p.normalize();
  for (int l = 0; l < level; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      auto key = std::make_pair(std::min(a, b), std::max(a, b));
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      return mid[key] = int(v.size()) - 1;
    };
    std::vector<Eigen::Vector3i> g;
    for (auto& x : f) {
      const int a = midpoint(x[0], x[1]), b = midpoint(x[1], x[2]), c = midpoint(x[2], x[0]);
      g.emplace_back(x[0], a, c);
      g.emplace_back(x[1], b, a);
      g.emplace_back(x[2], c, b);
      g.emplace_back(a, b, c);
    }
    f.swap(g);
  }
  for (auto& p : v) p *= r;
  return from_arrays(v, f, "icosphere");
}

/// Area of a face computed from its vertices.
inline double face_area(const Mesh& m, int f) {
  const Eigen::Vector3d a = m.vertices.row(m.faces(f, 0)).transpose();
  const Eigen::Vector3d b = m.vertices.row(m.faces(f, 1)).transpose();
  const Eigen::Vector3d c = m.vertices.row(m.faces(f, 2)).transpose();
  return 0.5 * (b - a).cross(c - a).norm();
}

inline Eigen::Vector3d face_normal(const Mesh& m, int f) {
  const Eigen::Vector3d a = m.vertices.row(m.faces(f, 0)).transpose();
  const Eigen::Vector3d b = m.vertices.row(m.faces(f, 1)).transpose();
  const Eigen::Vector3d c = m.vertices.row(m.faces(f, 2)).transpose();
  return (b - a).cross(c - a).normalized();
}

inline double mesh_area(const Mesh& m) {
  double s = 0.0;
  for (int f = 0; f < m.faces.rows(); ++f) s += face_area(m, f);
  return s;
}

/// Coefficient of variation (population standard deviation / mean).
inline double cv(const Eigen::VectorXd& x) {
  const double mean = x.mean();
  return std::sqrt((x.array() - mean).square().mean()) / mean;
}

}  // namespace surface_test
