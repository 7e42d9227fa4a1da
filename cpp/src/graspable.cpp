// Where a force-closure grasp can be: friction cones of the free surface's normals within the
// hand's span (see graspable.hpp for the argument and the method).
#include <pairgrasp/error.hpp>
#include <pairgrasp/graspable.hpp>

#include "surface_grid.hpp"
#include "thread_pool.hpp"

#include <algorithm>
#include <bitset>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

namespace pairgrasp {

namespace {

constexpr int kSide = 32;                        // bins per cube-face side
constexpr int kBins = 6 * kSide * kSide;         // directions of the cube map
constexpr double kSamplesPerSpan = 12.0;         // sample spacing and cell edge span / 12
constexpr int kCapSteps = 64;                    // Badoiu-Clarkson steps
constexpr double kMaxSamples = 2e7;
using Bins = std::bitset<kBins>;

// The cube-map face point (axis a, sign s, coordinates u, v in [-1, 1] along the two other axes).
Eigen::Vector3d cube_point(int face, double u, double v) {
  const int a = face / 2;
  Eigen::Vector3d d;
  d[a] = face % 2 ? -1.0 : 1.0;
  d[(a + 1) % 3] = u;
  d[(a + 2) % 3] = v;
  return d.normalized();
}

int bin_of(const Eigen::Vector3d& d) {
  int a = 0;
  for (int k = 1; k < 3; ++k)
    if (std::abs(d[k]) > std::abs(d[a])) a = k;
  const double m = std::abs(d[a]);
  auto cell = [&](double t) { return std::clamp(static_cast<int>(std::floor((t / m + 1.0) * 0.5 * kSide)), 0, kSide - 1); };
  const int face = 2 * a + (d[a] < 0.0 ? 1 : 0);
  return (face * kSide + cell(d[(a + 1) % 3])) * kSide + cell(d[(a + 2) % 3]);
}

// Bin centres and the largest angle between a bin's centre and any direction of the bin (reached
// at a corner: a cap is a convex region of the cube face's plane).
struct CubeMap {
  std::vector<Eigen::Vector3d> centre;
  double radius = 0.0;
  CubeMap() : centre(kBins) {
    const double w = 2.0 / kSide;
    for (int face = 0; face < 6; ++face)
      for (int i = 0; i < kSide; ++i)
        for (int j = 0; j < kSide; ++j) {
          const double u = -1.0 + (i + 0.5) * w, v = -1.0 + (j + 0.5) * w;
          const Eigen::Vector3d c = cube_point(face, u, v);
          centre[(face * kSide + i) * kSide + j] = c;
          for (int cu = 0; cu < 2; ++cu)
            for (int cv = 0; cv < 2; ++cv) {
              const Eigen::Vector3d corner = cube_point(face, -1.0 + (i + cu) * w, -1.0 + (j + cv) * w);
              radius = std::max(radius, std::acos(std::clamp(c.dot(corner), -1.0, 1.0)));
            }
        }
    radius += 1e-9;
  }
};

const CubeMap& cube_map() {
  static const CubeMap map;
  return map;
}

constexpr double kMaxCells = double((1 << 21) - 8);  // per axis: GridFrame keeps the cell as asked

// The smallest half angle (radians) of a cap about one direction holding every centre of `bins`
// that the search finds: from the mean direction, Badoiu-Clarkson steps towards the minimum
// enclosing ball of the centres. An upper bound of the minimum; pi when the bins surround the origin.
double enclosing_cap(const std::vector<int>& bins, const Eigen::Vector3d& mean, const CubeMap& map) {
  Eigen::Vector3d c = mean;
  double best = 3.14159265358979323846;
  for (int step = 0; step <= kCapSteps; ++step) {
    const double n = c.norm();
    if (!(n > 1e-12)) break;
    const Eigen::Vector3d v = c / n;
    double lowest = 2.0;
    int far = bins.front();
    for (int b : bins) {
      const double d = v.dot(map.centre[b]);
      if (d < lowest) lowest = d, far = b;
    }
    best = std::min(best, std::acos(std::clamp(lowest, -1.0, 1.0)));
    c += (map.centre[far] - c) / static_cast<double>(step + 2);
  }
  return best;
}

// An occupied cell of the sample grid: its centre and the bins of its samples' inward normals.
struct Cell {
  Eigen::Vector3d centre;
  std::vector<int> bins;  // ascending, distinct
};

}  // namespace

GraspableFaces graspable_faces(const Mesh& mesh, const Mask& free, double span, double mu, int threads) {
  if (!(span > 0.0) || !std::isfinite(span))
    throw std::invalid_argument("span: expected a finite length > 0 (m), got " + std::to_string(span));
  if (!(mu >= 0.0) || !std::isfinite(mu))
    throw std::invalid_argument("mu: expected a finite number >= 0, got " + std::to_string(mu));
  const Eigen::Index nf = mesh.faces.rows();
  if (free.size() != 0) detail::check_size("free: size", static_cast<long>(nf), static_cast<long>(free.size()));
  if (!mesh.vertices.allFinite()) throw std::invalid_argument("mesh: non-finite vertices");
  const CubeMap& map = cube_map();

  GraspableFaces out;
  out.faces = Mask::Constant(nf, false);
  out.limit = 0.5 * 3.14159265358979323846 - std::atan(mu) - map.radius;
  auto is_free = [&](Eigen::Index f) { return free.size() == 0 || free[f]; };

  // Samples of the free faces, every point of a face within `spacing` of one of its samples; the
  // sample grid's cells have that edge too.
  const double spacing = span / kSamplesPerSpan;
  std::vector<int> steps(static_cast<std::size_t>(nf), 0);
  double total = 0.0;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (Eigen::Index f = 0; f < nf; ++f) {
    if (!is_free(f)) continue;
    ++out.free;
    double longest = 0.0;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, k)).transpose();
      const Eigen::Vector3d b = mesh.vertices.row(mesh.faces(f, (k + 1) % 3)).transpose();
      longest = std::max(longest, (b - a).norm());
      lo = lo.cwiseMin(a), hi = hi.cwiseMax(a);
    }
    const double n = std::max(1.0, std::ceil(longest / spacing));
    steps[static_cast<std::size_t>(f)] = static_cast<int>(n);
    total += (n + 1.0) * (n + 2.0) / 2.0;
  }
  if (out.free == 0) return out;
  if (!(out.limit > 0.0)) {  // friction so high that no cone of normals can be ruled out
    for (Eigen::Index f = 0; f < nf; ++f) out.faces[f] = is_free(f);
    out.graspable = out.free;
    return out;
  }
  if (total > kMaxSamples || ((hi - lo) / spacing).maxCoeff() > kMaxCells)
    throw std::invalid_argument("span: " + std::to_string(span) + " m is too small for a target " +
                                std::to_string((hi - lo).maxCoeff()) + " m across");

  // Per face the cells of its samples; per occupied cell the bins of its samples' inward normals.
  const detail::GridFrame frame(lo, hi, spacing);
  std::unordered_map<std::uint64_t, std::size_t> index;
  std::vector<Cell> cells;
  std::vector<std::vector<std::size_t>> face_cells(static_cast<std::size_t>(nf));
  for (Eigen::Index f = 0; f < nf; ++f) {
    const int n = steps[static_cast<std::size_t>(f)];
    if (n == 0) continue;
    const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, 0)).transpose();
    const Eigen::Vector3d ab = mesh.vertices.row(mesh.faces(f, 1)).transpose() - a;
    const Eigen::Vector3d ac = mesh.vertices.row(mesh.faces(f, 2)).transpose() - a;
    const Eigen::Vector3d normal = ab.cross(ac);
    if (!(normal.norm() > 0.0)) continue;  // degenerate: no contact normal, no contact
    const int bin = bin_of(-normal.normalized());
    auto& mine = face_cells[static_cast<std::size_t>(f)];
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        const Eigen::Vector3d p = a + (double(i) / n) * ab + (double(j) / n) * ac;
        const Eigen::Array3i g = frame.coords(p.data());
        const auto [it, fresh] = index.emplace(detail::GridFrame::key(g[0], g[1], g[2]), cells.size());
        if (fresh) cells.push_back(Cell{lo + spacing * (g.cast<double>() + 0.5).matrix(), {}});
        std::vector<int>& bins = cells[it->second].bins;
        if (std::find(bins.begin(), bins.end(), bin) == bins.end()) bins.push_back(bin);
        mine.push_back(it->second);
      }
    std::sort(mine.begin(), mine.end());
    mine.erase(std::unique(mine.begin(), mine.end()), mine.end());
  }

  // A point x of a face lies within `spacing` of a sample, in a cell whose centre is within
  // spacing * sqrt(3) / 2 of it; the same holds for every surface point y within span of x. So the
  // cells whose centres lie within `reach` of a cell's centre hold every normal near its samples.
  const double reach = span + spacing * (2.0 + std::sqrt(3.0));
  detail::StaticGrid buckets;
  buckets.build(detail::GridFrame(lo, hi, reach), cells.size(), [&](std::size_t k) { return cells[k].centre.data(); });

  // Verdict per cell: the cone found (radians) when hopeless, -1 when not.
  const double least_mean = std::cos(std::max(0.0, out.limit));
  std::vector<double> cone(cells.size(), -1.0);
  detail::parallel_chunks(cells.size(), threads, [&](std::size_t begin, std::size_t end, int) {
    Bins seen;
    std::vector<int> bins;
    for (std::size_t k = begin; k < end; ++k) {
      seen.reset();
      bins.clear();
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      const Eigen::Array3i b = buckets.frame().coords(cells[k].centre.data());
      for (int ring = 0; ring <= 1; ++ring)
        detail::for_each_ring_cell(b, ring, [&](int x, int y, int z) {
          const auto [first, last] = buckets.cell(x, y, z);
          for (std::uint32_t i = first; i < last; ++i) {
            const std::size_t q = buckets.items()[i];
            if ((cells[q].centre - cells[k].centre).squaredNorm() > reach * reach) continue;
            for (int bin : cells[q].bins)
              if (!seen.test(static_cast<std::size_t>(bin))) {
                seen.set(static_cast<std::size_t>(bin));
                bins.push_back(bin);
                sum += map.centre[bin];
              }
          }
        });
      // Centres within `limit` of one direction v have a mean whose component along v is at least
      // cos(limit): a shorter mean proves the bins surround too much.
      const Eigen::Vector3d mean = sum / static_cast<double>(bins.size());
      if (mean.norm() < least_mean) continue;
      const double angle = enclosing_cap(bins, mean, map);
      if (angle <= out.limit - 1e-9) cone[k] = angle + map.radius;
    }
  });

  for (Eigen::Index f = 0; f < nf; ++f) {
    const auto& mine = face_cells[static_cast<std::size_t>(f)];
    const bool graspable = std::any_of(mine.begin(), mine.end(), [&](std::size_t k) { return cone[k] < 0.0; });
    out.faces[f] = graspable;
    if (graspable) ++out.graspable;
  }
  for (double a : cone) out.widest_cone = std::max(out.widest_cone, a);
  return out;
}

}  // namespace pairgrasp
