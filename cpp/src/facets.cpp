// Unit facets by a discrete, normal-aware centroidal Voronoi tessellation of the surface.
//
// 1. Every mesh face is cut into pieces by square cells of side h/4 laid out in its plane (rows
//    along its longest edge), so slivers give few pieces. The pieces of a face add up to its area
//    (scaled to the face's cross-product area); a face smaller than h/4 stays one piece.
// 2. Seeds: the pieces are visited in a fixed pseudo-random order and a piece becomes a seed
//    unless a seed within r = 0.745 h is *compatible* with it: same paint (free/occluded) and
//    normals within 60 degrees. Thin walls and sharp edges thus never share a facet, and every
//    region cut off that way (however small) receives a seed. Random sequential adsorption at
//    this radius leaves about one seed per (sqrt(3)/2) h^2, the cell of a hexagonal lattice of
//    spacing h, whatever the mesh.
// 3. Lloyd iterations (at most 10): each piece joins its nearest compatible seed (ties to the
//    lower seed index); each seed moves to its cell's area-weighted centroid and takes the face
//    (normal, paint) of the member piece nearest to it. This equalises the cell areas that random
//    seeding leaves uneven (area CV about 0.12-0.17, limited by the h/4 pieces).
// 4. A facet is a seed's cell: area = the sum of its pieces' areas (so the facet areas add up to
//    the mesh area, and each side of a sharp edge or paint border keeps exactly its own area);
//    centre = the point of the face under the member piece nearest the centroid that is closest
//    to the centroid (on the surface); normal and paint = those of that face.
// Everything runs in a fixed order (the parallel step only assigns pieces, independently), so the
// result is the same on every run and with any thread count.
#include <pairgrasp/error.hpp>
#include <pairgrasp/facets.hpp>

#include "surface_query_internal.hpp"
#include "surface_grid.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace pairgrasp {
namespace {

constexpr double kFacetAreaPerEdge2 = 0.86602540378443865;  // sqrt(3)/2: hexagonal cell of spacing h
constexpr double kPieceCell = 0.25;     // side of the square cells cutting faces into pieces, in units of h
constexpr double kSeedRadius = 0.745;   // Poisson-disk radius, in units of h (gives about (sqrt(3)/2) h^2 per facet)
constexpr double kNormalCos = 0.5;      // normals within 60 degrees may share a facet
constexpr int kLloydIterations = 10;
constexpr double kLloydStill = 1e-3;   // stop when no seed moves more than this, in units of h
constexpr double kFitMargin = 1.01;

// v rounded up to 4 significant digits (so a printed edge that "fits" still fits).
double ceil4(double v) {
  const double scale = std::pow(10.0, 3 - std::floor(std::log10(v)));
  return std::ceil(v * scale) / scale;
}

std::string fmt(double v) {
  std::ostringstream s;
  s.precision(4);
  s << v;
  return s.str();
}

struct Pieces {
  std::vector<double> xyz;             // 3 per piece: centroid
  std::vector<std::int32_t> face;      // source face
  std::vector<double> area;            // m^2
  std::size_t size() const { return face.size(); }
  const double* p(std::size_t k) const { return &xyz[3 * k]; }
};

// A convex polygon in a face's 2-D frame (a triangle clipped by at most 4 half-planes).
struct Poly {
  double x[8], y[8];
  int n = 0;
};

// Keeps the part of `in` with coordinate (axis 0: x, 1: y) >= v (keep_above) or <= v.
Poly clip(const Poly& in, int axis, double v, bool keep_above) {
  Poly out;
  for (int i = 0; i < in.n; ++i) {
    const int j = (i + 1) % in.n;
    const double ci = (axis == 0 ? in.x[i] : in.y[i]) - v, cj = (axis == 0 ? in.x[j] : in.y[j]) - v;
    const bool ii = keep_above ? ci >= 0 : ci <= 0, ij = keep_above ? cj >= 0 : cj <= 0;
    if (ii) out.x[out.n] = in.x[i], out.y[out.n] = in.y[i], ++out.n;
    if (ii != ij) {
      const double t = ci / (ci - cj);
      out.x[out.n] = in.x[i] + t * (in.x[j] - in.x[i]);
      out.y[out.n] = in.y[i] + t * (in.y[j] - in.y[i]);
      if (axis == 0) out.x[out.n] = v; else out.y[out.n] = v;
      ++out.n;
    }
  }
  return out;
}

// Cuts one face into pieces: its intersection with square cells of side `cell` laid out in the
// face's plane (rows parallel to the longest edge). A sliver thus gives about length/cell pieces,
// not (length/cell)^2. Piece areas are scaled to add up to the face's area exactly (to rounding).
void cut_face(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, double face_area,
              int f, double cell, Pieces& out) {
  const Eigen::Vector3d v[3] = {a, b, c};
  int k = 0;  // longest edge: v[k] -> v[k+1]
  double longest = -1.0;
  for (int i = 0; i < 3; ++i) {
    const double e = (v[(i + 1) % 3] - v[i]).squaredNorm();
    if (e > longest) longest = e, k = i;
  }
  const Eigen::Vector3d o = v[k];
  const Eigen::Vector3d ex = (v[(k + 1) % 3] - o).normalized();
  Eigen::Vector3d ey = (v[(k + 2) % 3] - o) - ex.dot(v[(k + 2) % 3] - o) * ex;
  const double height = ey.norm();
  const std::size_t first = out.face.size();
  if (!(height > 0.0) || std::sqrt(longest) <= cell) {  // one piece
    const Eigen::Vector3d g = (a + b + c) / 3.0;
    out.xyz.insert(out.xyz.end(), {g[0], g[1], g[2]});
    out.face.push_back(f);
    out.area.push_back(face_area);
    return;
  }
  ey /= height;
  Poly tri;
  tri.n = 3;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d d = v[(k + i) % 3] - o;
    tri.x[i] = d.dot(ex);
    tri.y[i] = d.dot(ey);
  }
  tri.x[0] = tri.y[0] = tri.y[1] = 0.0;
  tri.y[2] = height;
  double sum = 0.0;
  const int rows = std::max(1, int(std::ceil(height / cell)));
  for (int r = 0; r < rows; ++r) {
    Poly strip = tri;
    if (r > 0) strip = clip(strip, 1, r * cell, true);
    if (r + 1 < rows) strip = clip(strip, 1, (r + 1) * cell, false);
    if (strip.n < 3) continue;
    double x0 = strip.x[0], x1 = strip.x[0];
    for (int i = 1; i < strip.n; ++i) x0 = std::min(x0, strip.x[i]), x1 = std::max(x1, strip.x[i]);
    const int cols = std::max(1, int(std::ceil((x1 - x0) / cell)));
    for (int q = 0; q < cols; ++q) {
      Poly piece = strip;
      if (q > 0) piece = clip(piece, 0, x0 + q * cell, true);
      if (q + 1 < cols) piece = clip(piece, 0, x0 + (q + 1) * cell, false);
      if (piece.n < 3) continue;
      double ar = 0.0, cx = 0.0, cy = 0.0;
      for (int i = 0; i < piece.n; ++i) {
        const int j = (i + 1) % piece.n;
        const double w = piece.x[i] * piece.y[j] - piece.x[j] * piece.y[i];
        ar += w;
        cx += (piece.x[i] + piece.x[j]) * w;
        cy += (piece.y[i] + piece.y[j]) * w;
      }
      if (!(ar > 0.0)) continue;
      cx /= 3.0 * ar;
      cy /= 3.0 * ar;
      const Eigen::Vector3d g = o + cx * ex + cy * ey;
      out.xyz.insert(out.xyz.end(), {g[0], g[1], g[2]});
      out.face.push_back(f);
      out.area.push_back(0.5 * ar);
      sum += 0.5 * ar;
    }
  }
  if (out.face.size() == first) {  // every piece vanished to rounding: keep the face whole
    const Eigen::Vector3d g = (a + b + c) / 3.0;
    out.xyz.insert(out.xyz.end(), {g[0], g[1], g[2]});
    out.face.push_back(f);
    out.area.push_back(face_area);
    return;
  }
  const double scale = face_area / sum;
  for (std::size_t i = first; i < out.face.size(); ++i) out.area[i] *= scale;
}

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

using geometry_detail::closest_on_triangle;

struct Nearest {
  double d2 = std::numeric_limits<double>::infinity();
  std::int32_t seed = -1;
  void offer(double dd, std::int32_t s) {
    if (dd < d2 || (dd == d2 && s < seed)) d2 = dd, seed = s;
  }
};


// Face data shared by every run at any edge.
struct Surface {
  const Mesh* mesh = nullptr;
  Points fnormal;
  std::vector<double> farea;
  std::vector<char> fpaint;
  double total_area = 0.0;
};

Surface prepare(const Mesh& mesh, const Mask& free_faces) {
  const long F = mesh.faces.rows(), V = mesh.vertices.rows();
  if (F == 0) throw std::invalid_argument("mesh: has no faces");
  if (free_faces.size() != 0) detail::check_size("free_faces", F, free_faces.size());
  if (!mesh.vertices.allFinite()) throw std::invalid_argument("mesh: vertices contain NaN or infinity");
  for (long f = 0; f < F; ++f)
    for (int k = 0; k < 3; ++k)
      if (mesh.faces(f, k) < 0 || mesh.faces(f, k) >= V)
        throw std::invalid_argument("mesh: face " + std::to_string(f) + " refers to vertex " +
                                    std::to_string(mesh.faces(f, k)) + ", but there are " +
                                    std::to_string(V) + " vertices");
  Surface s;
  s.mesh = &mesh;
  s.fnormal.resize(F, 3);
  s.farea.resize(F);
  s.fpaint.assign(F, 1);
  for (long f = 0; f < F; ++f) {
    const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, 0)).transpose();
    const Eigen::Vector3d b = mesh.vertices.row(mesh.faces(f, 1)).transpose();
    const Eigen::Vector3d c = mesh.vertices.row(mesh.faces(f, 2)).transpose();
    const Eigen::Vector3d n = (b - a).cross(c - a);
    const double len = n.norm();
    s.farea[f] = 0.5 * len;
    if (len > 0.0)
      s.fnormal.row(f) = (n / len).transpose();
    else
      s.fnormal.row(f).setZero();
    if (free_faces.size() != 0) s.fpaint[f] = free_faces[f] ? 1 : 0;
    s.total_area += s.farea[f];
  }
  if (!(s.total_area > 0.0) || !std::isfinite(s.total_area))
    throw std::invalid_argument("mesh: has no finite, non-zero surface area");
  return s;
}

// Tessellates at `edge`. Returns false (with `count` = the facet count, or an estimate of it)
// when the result would exceed max_facets.
bool run(const Surface& surf, double edge, long max_facets, UnitFacets& out, double& count) {
  const Mesh& mesh = *surf.mesh;
  const long F = mesh.faces.rows();
  const Points& fnormal = surf.fnormal;
  const std::vector<double>& farea = surf.farea;
  const std::vector<char>& fpaint = surf.fpaint;
  const double total_area = surf.total_area;
  const double estimate = total_area / (kFacetAreaPerEdge2 * edge * edge);
  if (estimate > 1.5 * double(max_facets)) {
    count = estimate;
    return false;
  }

  // ------------------------------------------------------------------ 1. pieces
  Pieces pieces;
  const double piece_cell = kPieceCell * edge;
  {
    const std::size_t guess = std::size_t(total_area / (piece_cell * piece_cell)) + 2 * F;
    pieces.xyz.reserve(3 * guess);
    pieces.face.reserve(guess);
    pieces.area.reserve(guess);
  }
  for (long f = 0; f < F; ++f) {
    if (farea[f] <= 0.0) continue;  // a zero-area face adds nothing and has no normal
    cut_face(mesh.vertices.row(mesh.faces(f, 0)).transpose(), mesh.vertices.row(mesh.faces(f, 1)).transpose(),
             mesh.vertices.row(mesh.faces(f, 2)).transpose(), farea[f], int(f), piece_cell, pieces);
  }
  const std::size_t S = pieces.size();
  if (S > std::size_t(std::numeric_limits<std::int32_t>::max()))
    throw std::invalid_argument("edge: " + fmt(edge) + " m cuts this mesh into too many pieces");

  auto compatible = [&](int fa, int fb) {
    if (fpaint[fa] != fpaint[fb]) return false;
    return fnormal.row(fa).dot(fnormal.row(fb)) >= kNormalCos;
  };
  auto d2 = [](const double* a, const double* b) {
    const double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
    return x * x + y * y + z * z;
  };

  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (std::size_t k = 0; k < S; ++k)
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], pieces.p(k)[a]), hi[a] = std::max(hi[a], pieces.p(k)[a]);
  const double radius = kSeedRadius * edge;
  const detail::GridFrame frame(lo, hi, radius);
  const double cell = frame.cell();
  const double diag = (hi - lo).norm();

  // ------------------------------------------------------------------ 2. greedy Poisson-disk seeds
  // Pieces are visited in a fixed pseudo-random order (random sequential adsorption): a scan in
  // mesh order would lock onto the pieces' square lattice and make the density depend on it.
  std::vector<std::int32_t> seed_piece;  // piece index of each seed
  {
    std::vector<std::pair<std::uint64_t, std::int32_t>> order(S);
    for (std::size_t k = 0; k < S; ++k) order[k] = {splitmix64(k), std::int32_t(k)};
    std::sort(order.begin(), order.end());
    std::unordered_map<std::uint64_t, std::vector<std::int32_t>> grid;
    grid.reserve(std::size_t(estimate * 1.5) + 16);
    const double r2 = radius * radius;
    double visited_area = 0.0;
    for (const auto& ok : order) {
      const std::int32_t k = ok.second;
      visited_area += pieces.area[k];
      const double* p = pieces.p(k);
      const auto c = frame.coords(p);
      bool covered = false;
      for (int dx = -1; dx <= 1 && !covered; ++dx)
        for (int dy = -1; dy <= 1 && !covered; ++dy)
          for (int dz = -1; dz <= 1 && !covered; ++dz) {
            if (!detail::GridFrame::valid(c[0] + dx, c[1] + dy, c[2] + dz)) continue;
            auto it = grid.find(detail::GridFrame::key(c[0] + dx, c[1] + dy, c[2] + dz));
            if (it == grid.end()) continue;
            for (std::int32_t s : it->second) {
              const std::int32_t q = seed_piece[s];
              if (d2(pieces.p(q), p) < r2 && compatible(pieces.face[q], pieces.face[k])) {
                covered = true;
                break;
              }
            }
          }
      if (covered) continue;
      if (seed_piece.size() >= 2 * std::size_t(max_facets)) {  // far over: extrapolate from the area visited
        count = double(seed_piece.size()) * total_area / std::max(visited_area, 1e-300);
        return false;
      }
      grid[detail::GridFrame::key(c[0], c[1], c[2])].push_back(std::int32_t(seed_piece.size()));
      seed_piece.push_back(k);
    }
  }

  // ------------------------------------------------------------------ 3. Lloyd iterations
  // Pieces regrouped by grid cell (fixed for all iterations), contiguous per cell.
  detail::StaticGrid piece_grid;
  piece_grid.build(frame, S, [&](std::size_t k) { return pieces.p(k); });
  {
    const auto& perm = piece_grid.items();
    Pieces sorted;
    sorted.xyz.resize(3 * S);
    sorted.face.resize(S);
    sorted.area.resize(S);
    std::vector<std::int32_t> inv(S);
    for (std::size_t q = 0; q < S; ++q) {
      const std::uint32_t k = perm[q];
      for (int j = 0; j < 3; ++j) sorted.xyz[3 * q + j] = pieces.xyz[3 * k + j];
      sorted.face[q] = pieces.face[k];
      sorted.area[q] = pieces.area[k];
      inv[k] = std::int32_t(q);
    }
    pieces = std::move(sorted);
    for (auto& sp : seed_piece) sp = inv[sp];
  }
  const auto piece_cells = piece_grid.sorted_cells();  // ranges now index the sorted pieces
  const int threads = detail::resolve_threads(0, piece_cells.size() / 64 + 1);
  std::vector<std::int32_t> owner(S, -1);

  // Seeds: a free position (the cell centroid once Lloyd has moved it) and a face giving its
  // normal and paint (that of the member piece nearest the centroid).
  const std::size_t N = seed_piece.size();
  std::vector<double> seed_pos(3 * N);
  std::vector<std::int32_t> seed_face(N);
  for (std::size_t s = 0; s < N; ++s) {
    for (int j = 0; j < 3; ++j) seed_pos[3 * s + j] = pieces.p(seed_piece[s])[j];
    seed_face[s] = pieces.face[seed_piece[s]];
  }

  struct Cand {
    double p[3];
    double n[3];
    std::int32_t seed;
    std::int32_t paint;
  };
  auto assign = [&]() {
    std::vector<Cand> seeds(N);
    for (std::size_t s = 0; s < N; ++s) {
      const int f = seed_face[s];
      for (int j = 0; j < 3; ++j) seeds[s].p[j] = seed_pos[3 * s + j], seeds[s].n[j] = fnormal(f, j);
      seeds[s].seed = std::int32_t(s);
      seeds[s].paint = fpaint[f];
    }
    detail::StaticGrid seed_grid;
    seed_grid.build(frame, N, [&](std::size_t s) { return seeds[s].p; });
    detail::parallel_chunks(piece_cells.size(), threads, [&](std::size_t cb, std::size_t ce, int) {
      std::vector<Cand> cand;
      for (std::size_t ci = cb; ci < ce; ++ci) {
        const Eigen::Array3i c = detail::StaticGrid::decode(piece_cells[ci].first);
        cand.clear();
        for (int ring = 0; ring <= 1; ++ring)
          detail::for_each_ring_cell(c, ring, [&](int x, int y, int z) {
            const auto r = seed_grid.cell(x, y, z);
            for (auto q = r.first; q < r.second; ++q) cand.push_back(seeds[seed_grid.items()[q]]);
          });
        for (auto k = piece_cells[ci].second.first; k < piece_cells[ci].second.second; ++k) {
          const double* p = pieces.p(k);
          const int fk = pieces.face[k];
          const double nk[3] = {fnormal(fk, 0), fnormal(fk, 1), fnormal(fk, 2)};
          const int paint = fpaint[fk];
          Nearest best, any;
          auto offer = [&](const Cand& sd) {
            const double dd = d2(sd.p, p);
            any.offer(dd, sd.seed);
            if (sd.paint == paint && sd.n[0] * nk[0] + sd.n[1] * nk[1] + sd.n[2] * nk[2] >= kNormalCos)
              best.offer(dd, sd.seed);
          };
          for (const Cand& sd : cand) offer(sd);
          // Seeds outside the cells searched so far are at least (ring - 1) cells away.
          for (int ring = 2; !(best.d2 <= ((ring - 1) * cell) * ((ring - 1) * cell)); ++ring) {
            if ((ring - 2) * cell > diag) break;
            detail::for_each_ring_cell(c, ring, [&](int x, int y, int z) {
              const auto r = seed_grid.cell(x, y, z);
              for (auto q = r.first; q < r.second; ++q) offer(seeds[seed_grid.items()[q]]);
            });
          }
          owner[k] = best.seed >= 0 ? best.seed : any.seed;
        }
      }
    });
  };

  // Members of each seed nearest to a point per seed: (squared distance, piece).
  auto nearest_members = [&](const std::vector<double>& target) {
    std::vector<std::pair<double, std::int32_t>> near(N, {std::numeric_limits<double>::infinity(), -1});
    for (std::size_t k = 0; k < S; ++k) {
      const std::int32_t sd = owner[k];
      const double dd = d2(pieces.p(k), &target[3 * sd]);
      if (dd < near[sd].first) near[sd] = {dd, std::int32_t(k)};
    }
    return near;
  };

  const double still2 = std::pow(kLloydStill * edge, 2);
  for (int it = 0;; ++it) {
    assign();
    if (it == kLloydIterations) break;
    std::vector<double> sum(3 * N, 0.0), mass(N, 0.0);
    for (std::size_t k = 0; k < S; ++k) {
      const std::int32_t sd = owner[k];
      const double ar = pieces.area[k];
      mass[sd] += ar;
      for (int j = 0; j < 3; ++j) sum[3 * sd + j] += ar * pieces.p(k)[j];
    }
    double moved2 = 0.0;
    for (std::size_t sd = 0; sd < N; ++sd) {
      if (mass[sd] > 0.0)
        for (int j = 0; j < 3; ++j) sum[3 * sd + j] /= mass[sd];
      else
        for (int j = 0; j < 3; ++j) sum[3 * sd + j] = seed_pos[3 * sd + j];
      moved2 = std::max(moved2, d2(&sum[3 * sd], &seed_pos[3 * sd]));
    }
    const auto near = nearest_members(sum);
    for (std::size_t sd = 0; sd < N; ++sd)
      if (near[sd].second >= 0) seed_face[sd] = pieces.face[near[sd].second];
    seed_pos.swap(sum);
    if (moved2 <= still2) {  // converged: assign once more to the final positions and stop
      assign();
      break;
    }
  }

  // ------------------------------------------------------------------ 4. facets
  std::vector<double> area(N, 0.0);
  for (std::size_t k = 0; k < S; ++k) area[owner[k]] += pieces.area[k];
  const auto near = nearest_members(seed_pos);
  std::vector<std::int32_t> keep;  // seeds with members, in the order of their nearest piece
  keep.reserve(N);
  for (std::size_t sd = 0; sd < N; ++sd)
    if (area[sd] > 0.0 && near[sd].second >= 0) keep.push_back(std::int32_t(sd));
  std::sort(keep.begin(), keep.end(),
            [&](std::int32_t x, std::int32_t y) { return near[x].second < near[y].second; });
  count = double(keep.size());
  if (keep.size() > std::size_t(max_facets)) return false;

  const long M = long(keep.size());
  out.points.resize(M, 3);
  out.normals.resize(M, 3);
  out.areas.resize(M);
  out.face_ids.resize(M);
  out.free.resize(M);
  out.edge = edge;
  for (long i = 0; i < M; ++i) {
    const std::int32_t sd = keep[i];
    // The centre: the point of the face under the nearest member piece closest to the centroid.
    const int f = pieces.face[near[sd].second];
    const Eigen::Vector3d c = closest_on_triangle(Eigen::Map<const Eigen::Vector3d>(&seed_pos[3 * sd]),
                                                  mesh.vertices.row(mesh.faces(f, 0)).transpose(),
                                                  mesh.vertices.row(mesh.faces(f, 1)).transpose(),
                                                  mesh.vertices.row(mesh.faces(f, 2)).transpose());
    out.points.row(i) = c.transpose();
    out.normals.row(i) = fnormal.row(f);
    out.areas[i] = area[sd];
    out.face_ids[i] = f;
    out.free[i] = fpaint[f] != 0;
  }
  return true;
}

}  // namespace

UnitFacets tessellate(const Mesh& mesh, double edge, const Mask& free_faces, long max_facets) {
  if (!std::isfinite(edge) || edge <= 0.0)
    throw std::invalid_argument("edge: expected a positive finite length in metres, got " + fmt(edge));
  if (max_facets < 1)
    throw std::invalid_argument("max_facets: expected at least 1, got " + std::to_string(max_facets));
  const Surface surf = prepare(mesh, free_faces);
  UnitFacets out;
  double count = 0.0;
  if (run(surf, edge, max_facets, out, count)) return out;
  // Over the limit: find an edge that fits (facet counts scale about as edge^-2) by trying it.
  const double first = count;
  double fit = edge;
  UnitFacets probe;
  for (int iter = 0; iter < 12; ++iter) {
    fit *= std::sqrt(count / double(max_facets)) * kFitMargin;
    fit = ceil4(fit);
    if (run(surf, fit, max_facets, probe, count)) break;
  }
  throw std::invalid_argument("edge: " + fmt(edge) + " m gives " + (first > 1.5 * double(max_facets) ? "about " : "") +
                              std::to_string(static_cast<long long>(std::ceil(first))) +
                              " facets on this mesh (area " + fmt(surf.total_area) +
                              " m^2), more than max_facets = " + std::to_string(max_facets) +
                              "; the smallest edge that fits is about " + fmt(fit) + " m");
}

}  // namespace pairgrasp
