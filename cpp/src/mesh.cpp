// Mesh validation, clean-up (weld, degenerate/duplicate faces, unused vertices), orientation and
// mass properties. File loading is in mesh_io.cpp.
#include <pairgrasp/error.hpp>
#include <pairgrasp/mesh.hpp>

#include "mesh_internal.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <deque>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <unordered_map>
#include <utility>
#include <vector>

namespace pairgrasp {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMaxCoordinate = 1e100;  // metres; see build_mesh()

std::string format_number(double x) {
  std::ostringstream s;
  s.imbue(std::locale::classic());
  s.precision(17);
  s << x;
  return s.str();
}

std::string format_row(const Points& v, Eigen::Index i) {
  return "(" + format_number(v(i, 0)) + ", " + format_number(v(i, 1)) + ", " + format_number(v(i, 2)) +
         ")";
}

// ------------------------------------------------------------------------------------------ weld

struct CellKey {
  std::int64_t x, y, z;
  bool operator==(const CellKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct CellHash {
  std::size_t operator()(const CellKey& k) const {
    std::uint64_t h = static_cast<std::uint64_t>(k.x) * 0x9E3779B97F4A7C15ull;
    h ^= static_cast<std::uint64_t>(k.y) + 0x7F4A7C159E3779B9ull + (h << 6) + (h >> 2);
    h ^= static_cast<std::uint64_t>(k.z) + 0x94D049BB133111EBull + (h << 6) + (h >> 2);
    return static_cast<std::size_t>(h ^ (h >> 31));
  }
};

CellKey exact_key(const Points& v, Eigen::Index i) {
  // Bit patterns of the coordinates; adding 0.0 turns -0.0 into +0.0 so the two weld.
  CellKey k{};
  const double x = v(i, 0) + 0.0, y = v(i, 1) + 0.0, z = v(i, 2) + 0.0;
  std::memcpy(&k.x, &x, sizeof x);
  std::memcpy(&k.y, &y, sizeof y);
  std::memcpy(&k.z, &z, sizeof z);
  return k;
}

// rep[i] = the vertex that referenced vertex i is welded into (i itself when it is the first of
// its cluster), -1 for unreferenced vertices. A vertex joins the lowest-index earlier
// representative within `tol` (Euclidean). Exact copies (STL's usual case) are merged first by a
// hash of their coordinates; the distinct points then go through a grid with cells of 2*tol in
// which every cell that the ball of radius tol around a point touches is searched, so
// neighbours across cell boundaries are never missed.
void weld(const Points& v, const std::vector<char>& referenced, double tol, std::vector<int>& rep) {
  const Eigen::Index n = v.rows();
  rep.assign(static_cast<std::size_t>(n), -1);
  std::vector<int> distinct;
  {
    std::unordered_map<CellKey, int, CellHash> seen;
    seen.reserve(static_cast<std::size_t>(n));
    for (Eigen::Index i = 0; i < n; ++i) {
      if (!referenced[i]) continue;
      const auto [it, inserted] = seen.emplace(exact_key(v, i), static_cast<int>(i));
      rep[i] = it->second;
      if (inserted) distinct.push_back(static_cast<int>(i));
    }
  }
  double max_abs = 0.0;
  for (int i : distinct) max_abs = std::max(max_abs, v.row(i).cwiseAbs().maxCoeff());
  const double cell = 2.0 * tol;
  if (!(tol > 0.0) || !std::isfinite(cell) || !(max_abs / cell < 1e15)) return;  // exact only (cell indices must fit in int64)

  // Grid of the representatives: cell -> first one, next[] chains the rest of the cell.
  std::unordered_map<CellKey, int, CellHash> head;
  head.reserve(distinct.size());
  std::vector<int> next(static_cast<std::size_t>(n), -1);
  const double reach = tol * (1.0 + 1e-9);  // a hair more than tol against rounding in floor()
  const double tol2 = tol * tol;
  for (int i : distinct) {
    const Eigen::RowVector3d p = v.row(i);
    std::array<std::int64_t, 3> lo{}, hi{};
    for (int a = 0; a < 3; ++a) {
      lo[a] = static_cast<std::int64_t>(std::floor((p[a] - reach) / cell));
      hi[a] = static_cast<std::int64_t>(std::floor((p[a] + reach) / cell));
    }
    int best = -1;
    for (std::int64_t x = lo[0]; x <= hi[0]; ++x)
      for (std::int64_t y = lo[1]; y <= hi[1]; ++y)
        for (std::int64_t z = lo[2]; z <= hi[2]; ++z) {
          auto it = head.find(CellKey{x, y, z});
          if (it == head.end()) continue;
          for (int j = it->second; j >= 0; j = next[j])
            if ((best < 0 || j < best) && (v.row(j) - p).squaredNorm() <= tol2) best = j;
        }
    if (best >= 0) {
      rep[i] = best;
      continue;
    }
    const CellKey own{static_cast<std::int64_t>(std::floor(p[0] / cell)),
                      static_cast<std::int64_t>(std::floor(p[1] / cell)),
                      static_cast<std::int64_t>(std::floor(p[2] / cell))};
    auto [it, inserted] = head.emplace(own, i);
    if (!inserted) {
      next[i] = it->second;
      it->second = i;
    }
  }
  // Exact copies follow their first occurrence.
  for (Eigen::Index i = 0; i < n; ++i)
    if (referenced[i] && rep[i] != i) rep[i] = rep[rep[i]];
}

// ----------------------------------------------------------------------------------- orientation

struct HalfEdge {
  int a, b;      // a < b
  int face;
  bool forward;  // the face runs a -> b
};

// Solid angle subtended at the origin by triangle (a, b, c), signed by its winding
// (Van Oosterom and Strackee).
double solid_angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const double la = a.norm(), lb = b.norm(), lc = c.norm();
  const double num = a.dot(b.cross(c));
  const double den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
  return 2.0 * std::atan2(num, den);
}

struct Component {
  std::vector<int> faces;
  bool consistent = true;    // no conflict met while propagating the winding
  bool all_manifold = true;  // every edge of its faces is shared by exactly two faces
  double signed_volume6 = 0.0;  // 6 x signed volume with the propagated winding
  Eigen::AlignedBox3d box;
  bool closed() const { return consistent && all_manifold; }
};

Eigen::Vector3d corner(const Points& v, const Triangles& f, int face, int k) {
  return v.row(f(face, k)).transpose();
}

// Returns, per face, whether it must be flipped (see the orientation rules in mesh.hpp).
std::vector<char> orient_faces(const Points& v, const Triangles& f, const std::vector<HalfEdge>& edges) {
  const int nf = static_cast<int>(f.rows());
  // Neighbours through manifold edges: (other face, both run the edge the same way).
  std::vector<std::array<std::pair<int, bool>, 3>> adj(static_cast<std::size_t>(nf));
  std::vector<int> n_adj(static_cast<std::size_t>(nf), 0);
  std::vector<char> bad_edge(static_cast<std::size_t>(nf), 0);
  for (std::size_t s = 0; s < edges.size();) {
    std::size_t e = s;
    while (e < edges.size() && edges[e].a == edges[s].a && edges[e].b == edges[s].b) ++e;
    if (e - s == 2) {
      const HalfEdge& h0 = edges[s];
      const HalfEdge& h1 = edges[s + 1];
      const bool same = h0.forward == h1.forward;
      adj[h0.face][n_adj[h0.face]++] = {h1.face, same};
      adj[h1.face][n_adj[h1.face]++] = {h0.face, same};
    } else {
      for (std::size_t k = s; k < e; ++k) bad_edge[edges[k].face] = 1;
    }
    s = e;
  }

  std::vector<int> comp_of(static_cast<std::size_t>(nf), -1);
  std::vector<char> flip(static_cast<std::size_t>(nf), 0);
  std::vector<Component> comps;
  std::deque<int> queue;
  for (int seed = 0; seed < nf; ++seed) {
    if (comp_of[seed] >= 0) continue;
    const int c = static_cast<int>(comps.size());
    comps.emplace_back();
    Component& comp = comps.back();
    comp_of[seed] = c;
    queue.push_back(seed);
    while (!queue.empty()) {
      const int g = queue.front();
      queue.pop_front();
      comp.faces.push_back(g);
      if (bad_edge[g]) comp.all_manifold = false;
      for (int k = 0; k < n_adj[g]; ++k) {
        const auto [h, same] = adj[g][k];
        const char want = static_cast<char>(flip[g] ^ (same ? 1 : 0));
        if (comp_of[h] < 0) {
          comp_of[h] = c;
          flip[h] = want;
          queue.push_back(h);
        } else if (flip[h] != want) {
          comp.consistent = false;
        }
      }
    }
    std::sort(comp.faces.begin(), comp.faces.end());
  }

  // Signed volumes and boxes of the closed components, with the propagated winding.
  std::vector<int> closed_ids;
  for (int c = 0; c < static_cast<int>(comps.size()); ++c) {
    Component& comp = comps[c];
    if (!comp.closed()) continue;
    closed_ids.push_back(c);
    const Eigen::Vector3d o = corner(v, f, comp.faces.front(), 0);
    for (int g : comp.faces) {
      const Eigen::Vector3d a = corner(v, f, g, 0) - o, b = corner(v, f, g, 1) - o,
                            cc = corner(v, f, g, 2) - o;
      const double d = a.dot(b.cross(cc));
      comp.signed_volume6 += flip[g] ? -d : d;
      for (int k = 0; k < 3; ++k) comp.box.extend(corner(v, f, g, k));
    }
  }

  // Nesting depth of each closed component: how many other closed components hold it wholly
  // (a few of its vertices, all inside by winding number; boxes checked first).
  for (int c : closed_ids) {
    Component& comp = comps[c];
    int depth = 0;
    for (int d : closed_ids) {
      if (d == c || !comps[d].box.contains(comp.box)) continue;
      const Component& outer = comps[d];
      const std::size_t n = comp.faces.size();
      const std::size_t samples = std::min<std::size_t>(8, n);
      bool inside = true;
      for (std::size_t s = 0; s < samples && inside; ++s) {
        const Eigen::Vector3d p = corner(v, f, comp.faces[s * n / samples], 0);
        double omega = 0.0;
        for (int g : outer.faces) {
          const double w = solid_angle(corner(v, f, g, 0) - p, corner(v, f, g, 1) - p, corner(v, f, g, 2) - p);
          omega += flip[g] ? -w : w;
        }
        inside = std::abs(omega) > 2.0 * kPi;  // |winding number| > 1/2
      }
      if (inside) ++depth;
    }
    const double want_sign = (depth % 2 == 0) ? 1.0 : -1.0;
    if (comp.signed_volume6 * want_sign < 0.0)
      for (int g : comp.faces) flip[g] ^= 1;
  }

  // Open, non-manifold or non-orientable components (and flat closed ones): the majority of the
  // source faces decides.
  for (Component& comp : comps) {
    if (comp.closed() && comp.signed_volume6 != 0.0) continue;
    std::size_t flipped = 0;
    for (int g : comp.faces) flipped += flip[g] ? 1 : 0;
    if (2 * flipped > comp.faces.size())
      for (int g : comp.faces) flip[g] ^= 1;
  }
  return flip;
}

}  // namespace

// ------------------------------------------------------------------------------------ Mesh methods

Eigen::Vector3d Mesh::face_normal(int f) const {
  if (f < 0 || f >= faces.rows())
    throw std::invalid_argument("f: face index " + std::to_string(f) + " out of range [0, " +
                                std::to_string(faces.rows()) + ")");
  const Eigen::Vector3d a = vertices.row(faces(f, 0)), b = vertices.row(faces(f, 1)),
                        c = vertices.row(faces(f, 2));
  return (b - a).cross(c - a).normalized();
}

double Mesh::face_area(int f) const {
  if (f < 0 || f >= faces.rows())
    throw std::invalid_argument("f: face index " + std::to_string(f) + " out of range [0, " +
                                std::to_string(faces.rows()) + ")");
  const Eigen::Vector3d a = vertices.row(faces(f, 0)), b = vertices.row(faces(f, 1)),
                        c = vertices.row(faces(f, 2));
  return 0.5 * (b - a).cross(c - a).norm();
}

Points Mesh::face_normals() const {
  Points n(faces.rows(), 3);
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const Eigen::Vector3d a = vertices.row(faces(f, 0)), b = vertices.row(faces(f, 1)),
                          c = vertices.row(faces(f, 2));
    n.row(f) = (b - a).cross(c - a).normalized().transpose();
  }
  return n;
}

// ------------------------------------------------------------------------------------ build_mesh

namespace detail {

void check_mesh_options(const MeshLoadOptions& options) {
  if (!std::isfinite(options.scale) || options.scale <= 0.0)
    throw std::invalid_argument("scale: expected a finite positive number, got " + format_number(options.scale));
  if (!std::isfinite(options.weld_tolerance) || options.weld_tolerance < 0.0)
    throw std::invalid_argument("weld_tolerance: expected a finite number >= 0, got " +
                                format_number(options.weld_tolerance));
}

Mesh build_mesh(Points vertices, Triangles faces, std::string source, const MeshLoadOptions& options,
                const MeshFail& fail, double unit) {
  check_mesh_options(options);
  const Eigen::Index nv = vertices.rows();
  const Eigen::Index nf_in = faces.rows();

  // ---- validation
  for (Eigen::Index i = 0; i < nv; ++i)
    if (!vertices.row(i).allFinite()) fail("vertices", "vertex " + std::to_string(i) + " is not finite " + format_row(vertices, i));
  for (Eigen::Index f = 0; f < nf_in; ++f)
    for (int k = 0; k < 3; ++k)
      if (faces(f, k) < 0 || faces(f, k) >= nv)
        fail("faces", "face " + std::to_string(f) + " has index " + std::to_string(faces(f, k)) +
                          " out of range [0, " + std::to_string(nv) + ")");
  if (nf_in == 0) fail("faces", "no triangles");

  const double factor = unit * options.scale;
  if (factor != 1.0) {
    vertices *= factor;
    for (Eigen::Index i = 0; i < nv; ++i)
      if (!vertices.row(i).allFinite())
        fail("vertices", "vertex " + std::to_string(i) + " is not finite after scaling by " + format_number(factor));
  }
  // Areas, volumes and the weld grid square and cube coordinates: beyond this they overflow.
  for (Eigen::Index i = 0; i < nv; ++i)
    if (vertices.row(i).cwiseAbs().maxCoeff() > kMaxCoordinate)
      fail("vertices", "vertex " + std::to_string(i) + " " + format_row(vertices, i) + " lies beyond " +
                           format_number(kMaxCoordinate) + " m of the origin");

  // ---- weld the referenced vertices
  std::vector<char> referenced(static_cast<std::size_t>(nv), 0);
  Eigen::AlignedBox3d ref_box;
  for (Eigen::Index f = 0; f < nf_in; ++f)
    for (int k = 0; k < 3; ++k) {
      const int i = faces(f, k);
      if (!referenced[i]) {
        referenced[i] = 1;
        ref_box.extend(vertices.row(i).transpose());
      }
    }
  const double tol = options.weld_tolerance * ref_box.diagonal().norm();
  std::vector<int> rep;
  weld(vertices, referenced, tol, rep);
  int n_referenced = 0, n_reps = 0;
  for (Eigen::Index i = 0; i < nv; ++i) {
    n_referenced += referenced[i] ? 1 : 0;
    n_reps += (referenced[i] && rep[i] == i) ? 1 : 0;
  }

  // ---- degenerate and duplicate faces
  MeshCleanup cleanup;
  cleanup.welded_vertices = n_referenced - n_reps;
  std::vector<char> keep(static_cast<std::size_t>(nf_in), 1);
  std::vector<std::pair<std::array<int, 3>, int>> sorted;
  sorted.reserve(static_cast<std::size_t>(nf_in));
  for (Eigen::Index f = 0; f < nf_in; ++f) {
    std::array<int, 3> t{rep[faces(f, 0)], rep[faces(f, 1)], rep[faces(f, 2)]};
    faces.row(f) << t[0], t[1], t[2];
    bool degenerate = t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
    if (!degenerate) {
      const Eigen::Vector3d a = vertices.row(t[0]), b = vertices.row(t[1]), c = vertices.row(t[2]);
      const double longest =
          std::sqrt(std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()}));
      const double twice_area = (b - a).cross(c - a).norm();
      const double height = twice_area / longest;  // of the corner opposite the longest edge
      degenerate = twice_area == 0.0 || height <= std::max(tol, 1e-12 * longest);
    }
    if (degenerate) {
      keep[f] = 0;
      ++cleanup.degenerate_faces;
      continue;
    }
    std::sort(t.begin(), t.end());
    sorted.emplace_back(t, static_cast<int>(f));
  }
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t s = 1; s < sorted.size(); ++s)
    if (sorted[s].first == sorted[s - 1].first) {
      keep[sorted[s].second] = 0;
      ++cleanup.duplicate_faces;
    }
  const Eigen::Index nf = static_cast<Eigen::Index>(sorted.size()) - cleanup.duplicate_faces;
  if (nf == 0)
    fail("faces", "no triangles left after removing " + std::to_string(cleanup.degenerate_faces) +
                      " degenerate and " + std::to_string(cleanup.duplicate_faces) + " duplicate ones");

  // ---- drop unused vertices, keeping the source order
  std::vector<int> new_index(static_cast<std::size_t>(nv), -1);
  for (Eigen::Index f = 0; f < nf_in; ++f)
    if (keep[f])
      for (int k = 0; k < 3; ++k) new_index[faces(f, k)] = 0;
  int n_used = 0;
  for (Eigen::Index i = 0; i < nv; ++i)
    if (new_index[i] == 0) new_index[i] = n_used++;
  cleanup.unused_vertices = static_cast<int>(nv) - n_used - cleanup.welded_vertices;

  Mesh mesh;
  mesh.source = std::move(source);
  mesh.vertices.resize(n_used, 3);
  for (Eigen::Index i = 0; i < nv; ++i)
    if (new_index[i] >= 0) mesh.vertices.row(new_index[i]) = vertices.row(i);
  mesh.faces.resize(nf, 3);
  {
    Eigen::Index out = 0;
    for (Eigen::Index f = 0; f < nf_in; ++f)
      if (keep[f]) {
        for (int k = 0; k < 3; ++k) mesh.faces(out, k) = new_index[faces(f, k)];
        ++out;
      }
  }
  Points().swap(vertices);  // release the source copy early
  const Points& V = mesh.vertices;
  Triangles& F = mesh.faces;

  // ---- edges, orientation, closedness
  std::vector<HalfEdge> edges;
  edges.reserve(static_cast<std::size_t>(3 * nf));
  for (Eigen::Index f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      edges.push_back({std::min(a, b), std::max(a, b), static_cast<int>(f), a < b});
    }
  std::sort(edges.begin(), edges.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return std::tie(x.a, x.b, x.face) < std::tie(y.a, y.b, y.face);
  });
  std::vector<char> flip(static_cast<std::size_t>(nf), 0);
  if (options.orient) flip = orient_faces(V, F, edges);
  for (Eigen::Index f = 0; f < nf; ++f)
    if (flip[f]) {
      std::swap(F(f, 1), F(f, 2));
      ++cleanup.flipped_faces;
    }
  int inconsistent_edges = 0;
  for (std::size_t s = 0; s < edges.size();) {
    std::size_t e = s;
    while (e < edges.size() && edges[e].a == edges[s].a && edges[e].b == edges[s].b) ++e;
    if (e - s == 1) {
      ++mesh.boundary_edges;
    } else if (e - s > 2) {
      ++mesh.non_manifold_edges;
    } else {
      const bool f0 = edges[s].forward != static_cast<bool>(flip[edges[s].face]);
      const bool f1 = edges[s + 1].forward != static_cast<bool>(flip[edges[s + 1].face]);
      if (f0 == f1) ++inconsistent_edges;
    }
    s = e;
  }
  mesh.closed = mesh.boundary_edges == 0 && mesh.non_manifold_edges == 0 && inconsistent_edges == 0;
  mesh.cleanup = cleanup;

  // ---- measures (about the box centre, for round-off)
  for (Eigen::Index i = 0; i < V.rows(); ++i) mesh.bounds.extend(V.row(i).transpose());
  const Eigen::Vector3d o = mesh.bounds.center();
  double area = 0.0, volume6 = 0.0;
  Eigen::Vector3d surface_moment = Eigen::Vector3d::Zero(), volume_moment = Eigen::Vector3d::Zero();
  for (Eigen::Index f = 0; f < nf; ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)).transpose() - o, b = V.row(F(f, 1)).transpose() - o,
                          c = V.row(F(f, 2)).transpose() - o;
    const double fa = 0.5 * (b - a).cross(c - a).norm();
    const double d = a.dot(b.cross(c));
    area += fa;
    surface_moment += fa * (a + b + c) / 3.0;
    volume6 += d;
    volume_moment += d * (a + b + c);  // (d/6) * (a+b+c)/4 per tetrahedron, scaled by 24
  }
  mesh.area = area;
  // A closed surface that encloses no volume (flat, or whose parts' volumes cancel; with
  // orientation, also one left inside out) has no inside: it counts as open. "No volume" is
  // within the rounding of the signed sum, 1e-12 of the box diagonal cubed.
  const double diagonal = mesh.bounds.diagonal().norm();
  const double no_volume = 6e-12 * diagonal * diagonal * diagonal;
  if (mesh.closed && (options.orient ? !(volume6 > no_volume) : !(std::abs(volume6) > no_volume))) mesh.closed = false;
  if (mesh.closed) {
    mesh.volume = volume6 / 6.0;
    mesh.center_of_mass = o + volume_moment / (4.0 * volume6);
  } else {
    mesh.volume = 0.0;
    mesh.center_of_mass = o + surface_moment / area;
  }
  return mesh;
}

}  // namespace detail

// ------------------------------------------------------------------------------------ make_mesh

Mesh make_mesh(const Points& vertices, const Triangles& faces, const std::string& name,
               const MeshLoadOptions& options) {
  const detail::MeshFail fail = [&name](const std::string& argument, const std::string& message) {
    throw std::invalid_argument(argument + ": " + message + " (mesh '" + name + "')");
  };
  return detail::build_mesh(vertices, faces, name, options, fail);
}

}  // namespace pairgrasp
