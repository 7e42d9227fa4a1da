#pragma once
// Test meshes for the surface tests, built from their dimensions (independent of the library).
#include <pairgrasp/mesh.hpp>

#include "test_meshes.hpp"

#include <cmath>
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

/// Icosphere of radius r: an icosahedron subdivided `level` times, vertices pushed to the sphere
/// (the collision tests' construction).
inline Mesh icosphere(double r, int level) { return pairgrasp::testing_meshes::icosphere(r, level); }

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
