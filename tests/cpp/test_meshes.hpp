#pragma once
// Simple meshes with known geometry for the tests of surface queries, collision,
// closing, contacts). Built here from dimensions, independent of the library's mesh code.
#include <pairgrasp/mesh.hpp>

#include <array>
#include <cmath>
#include <map>
#include <vector>

namespace pairgrasp::testing_meshes {

/// Axis-aligned box [lo, hi], each face split into n x n squares (2 triangles each), outward.
inline Mesh box_mesh(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int n = 1,
                     const std::string& name = "box", bool inward = false) {
  std::vector<Eigen::Vector3d> v;
  std::vector<std::array<int, 3>> f;
  // For each axis and side, a grid on the face; winding from the cross product of the two
  // in-face axes chosen so that the normal points out.
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int u = (axis + 1) % 3, w = (axis + 2) % 3;
      const int base = static_cast<int>(v.size());
      for (int i = 0; i <= n; ++i)
        for (int j = 0; j <= n; ++j) {
          Eigen::Vector3d p;
          p[axis] = side ? hi[axis] : lo[axis];
          p[u] = lo[u] + (hi[u] - lo[u]) * i / n;
          p[w] = lo[w] + (hi[w] - lo[w]) * j / n;
          v.push_back(p);
        }
      auto id = [&](int i, int j) { return base + i * (n + 1) + j; };
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          // (u, w) is right-handed with the axis: e_u x e_w = e_axis.
          std::array<int, 3> t1 = {id(i, j), id(i + 1, j), id(i + 1, j + 1)};
          std::array<int, 3> t2 = {id(i, j), id(i + 1, j + 1), id(i, j + 1)};
          const bool flip = (side == 0) != inward;
          if (flip) {
            std::swap(t1[1], t1[2]);
            std::swap(t2[1], t2[2]);
          }
          f.push_back(t1);
          f.push_back(t2);
        }
    }
  Points V(v.size(), 3);
  for (size_t i = 0; i < v.size(); ++i) V.row(i) = v[i].transpose();
  Triangles F(f.size(), 3);
  for (size_t i = 0; i < f.size(); ++i) F.row(i) << f[i][0], f[i][1], f[i][2];
  MeshLoadOptions opt;
  opt.orient = false;  // the winding above is already outward; keep it as built
  return make_mesh(V, F, name, opt);
}

/// Appends mesh b's faces to a (as separate components).
inline Mesh merge(const Mesh& a, const Mesh& b, const std::string& name, bool orient = false) {
  Points V(a.vertices.rows() + b.vertices.rows(), 3);
  V << a.vertices, b.vertices;
  Triangles F(a.faces.rows() + b.faces.rows(), 3);
  F << a.faces, (b.faces.array() + static_cast<int>(a.vertices.rows())).matrix();
  MeshLoadOptions opt;
  opt.orient = orient;
  opt.weld_tolerance = 0.0;
  return make_mesh(V, F, name, opt);
}

/// Icosphere of radius r about c: an icosahedron subdivided `levels` times, vertices on the sphere.
inline Mesh icosphere(double r, int levels, const Eigen::Vector3d& c = Eigen::Vector3d::Zero()) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                                    {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                                    {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& p : v) p.normalize();
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::make_pair(std::min(a, b), std::max(a, b));
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      return mid[key] = static_cast<int>(v.size()) - 1;
    };
    std::vector<std::array<int, 3>> g;
    for (auto& tri : f) {
      const int a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), c = midpoint(tri[2], tri[0]);
      g.push_back({tri[0], a, c});
      g.push_back({tri[1], b, a});
      g.push_back({tri[2], c, b});
      g.push_back({a, b, c});
    }
    f = g;
  }
  Points V(v.size(), 3);
  for (size_t i = 0; i < v.size(); ++i) V.row(i) = (c + r * v[i]).transpose();
  Triangles F(f.size(), 3);
  for (size_t i = 0; i < f.size(); ++i) F.row(i) << f[i][0], f[i][1], f[i][2];
  return make_mesh(V, F, "icosphere");
}

}  // namespace pairgrasp::testing_meshes
