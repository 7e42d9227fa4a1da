#include <pairgrasp/error.hpp>
#include <pairgrasp/pair_index.hpp>

#include "pair_index_internal.hpp"
#include "surface_feature.hpp"
#include "surface_grid.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>

namespace pairgrasp {
namespace {

constexpr int kLeafSize = 16;           // leaves hold kLeafSize .. 2 * kLeafSize pairs
constexpr std::size_t kHistogramPairs = std::size_t(1) << 21;  // thinning: pairs enough to weigh the cells
constexpr double kUnitTolerance = 1e-6; // |1 - |n|| allowed for a unit normal

std::string fmt(double v, int precision = 4) {
  std::ostringstream s;
  s.precision(precision);
  s << v;
  return s.str();
}

void check_points(const char* what, const Points& p) {
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    if (!p.row(i).allFinite())
      throw std::invalid_argument(std::string(what) + ": row " + std::to_string(i) + " is not finite");
}

void check_normals(const Points& n) {
  check_points("normals", n);
  for (Eigen::Index i = 0; i < n.rows(); ++i) {
    const double len = n.row(i).norm();
    if (!(std::abs(len - 1.0) <= kUnitTolerance))
      throw std::invalid_argument("normals: row " + std::to_string(i) + " has length " + fmt(len, 8) +
                                  ", expected unit length");
  }
}

void check_d_max(double d_max) {
  if (!std::isfinite(d_max) || d_max <= 0.0)
    throw std::invalid_argument("d_max: expected a positive finite distance in metres, got " + fmt(d_max));
}

/// The free points' indices, and a grid of cell >= d_max over them.
struct PairGrid {
  std::vector<std::int32_t> active;  // indices of the points taking part
  detail::StaticGrid grid;           // over active (item k is point active[k])
};

PairGrid make_pair_grid(const Points& points, const Mask& free, double d_max) {
  PairGrid g;
  const Eigen::Index n = points.rows();
  g.active.reserve(n);
  for (Eigen::Index i = 0; i < n; ++i)
    if (free.size() == 0 || free[i]) g.active.push_back(std::int32_t(i));
  if (g.active.empty()) return g;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (auto i : g.active) {
    lo = lo.cwiseMin(points.row(i).transpose());
    hi = hi.cwiseMax(points.row(i).transpose());
  }
  g.grid.build(detail::GridFrame(lo, hi, d_max), g.active.size(),
               [&](std::size_t k) { return points.row(g.active[k]).data(); });
  return g;
}

/// Calls visit(i, j) for every pair i < j of active points with d <= d_max, for the points
/// active[kb..ke). Per point i, partners come in a fixed order.
template <class Visit>
void visit_pairs(const Points& points, const PairGrid& g, double d_max, std::size_t kb, std::size_t ke,
                 Visit visit) {
  const auto& items = g.grid.items();
  for (std::size_t k = kb; k < ke; ++k) {
    const std::int32_t i = g.active[k];
    const double* p = points.row(i).data();
    const Eigen::Array3i c = g.grid.frame().coords(p);
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto r = g.grid.cell(c[0] + dx, c[1] + dy, c[2] + dz);
          for (auto q = r.first; q < r.second; ++q) {
            const std::int32_t j = g.active[items[q]];
            if (j <= i) continue;
            const double* o = points.row(j).data();
            const double x = p[0] - o[0], y = p[1] - o[1], z = p[2] - o[2];
            const double d = std::sqrt(x * x + y * y + z * z);
            if (d <= d_max) visit(i, j);
          }
        }
  }
}

/// Whether pair (i, j) is stored: every pair, or (max_dot < 1) those with n_i.n_j <= max_dot.
struct NormalFilter {
  const Points* normals = nullptr;  // null: every pair
  double max_dot = 1.0;
  bool operator()(std::int32_t i, std::int32_t j) const {
    return !normals || normals->row(i).dot(normals->row(j)) <= max_dot;
  }
};

/// Per active point, the number of partners j > i within d_max that `keep` keeps.
std::vector<std::size_t> count_per_point(const Points& points, const PairGrid& g, double d_max, int threads,
                                         const NormalFilter& keep = {}) {
  std::vector<std::size_t> counts(g.active.size(), 0);
  detail::parallel_chunks(g.active.size(), threads, [&](std::size_t b, std::size_t e, int) {
    for (std::size_t k = b; k < e; ++k) {
      std::size_t c = 0;
      visit_pairs(points, g, d_max, k, k + 1, [&](std::int32_t i, std::int32_t j) { c += keep(i, j) ? 1 : 0; });
      counts[k] = c;
    }
  });
  return counts;
}

double median_nn_spacing(const Points& points, int threads) {
  const Eigen::Index n = points.rows();
  if (n < 2) return 0.0;
  const Eigen::Vector3d lo = points.colwise().minCoeff().transpose();
  const Eigen::Vector3d hi = points.colwise().maxCoeff().transpose();
  const double diag = (hi - lo).norm();
  if (!(diag > 0.0)) return 0.0;
  detail::StaticGrid grid;
  grid.build(detail::GridFrame(lo, hi, diag / std::sqrt(double(n))), std::size_t(n),
             [&](std::size_t i) { return points.row(Eigen::Index(i)).data(); });
  const double cell = grid.frame().cell();
  std::vector<double> nn(n);
  detail::parallel_chunks(std::size_t(n), threads, [&](std::size_t b, std::size_t e, int) {
    for (std::size_t i = b; i < e; ++i) {
      const double* p = points.row(Eigen::Index(i)).data();
      const Eigen::Array3i c = grid.frame().coords(p);
      double best = std::numeric_limits<double>::infinity();
      for (int ring = 0;; ++ring) {
        detail::for_each_ring_cell(c, ring, [&](int x, int y, int z) {
          const auto r = grid.cell(x, y, z);
          for (auto q = r.first; q < r.second; ++q) {
            const std::uint32_t j = grid.items()[q];
            if (j == i) continue;
            const double* o = points.row(j).data();
            const double dx = p[0] - o[0], dy = p[1] - o[1], dz = p[2] - o[2];
            best = std::min(best, dx * dx + dy * dy + dz * dz);
          }
        });
        // Points beyond ring r are farther than r cells.
        if (best <= (ring * cell) * (ring * cell) || ring * cell > 2 * diag + cell) break;
      }
      nn[i] = std::sqrt(best);
    }
  });
  const std::size_t mid = nn.size() / 2;
  std::nth_element(nn.begin(), nn.begin() + mid, nn.end());
  double m = nn[mid];
  if (nn.size() % 2 == 0) m = 0.5 * (m + *std::max_element(nn.begin(), nn.begin() + mid));
  return m;
}

/// The thinning's cells over the feature space (d in [0, d_max], n_i.n_j in [-1, 1], beta in
/// [-2, 2]), indexed from the float32 feature as stored, so that the build and weight() agree.
struct FeatureCells {
  Eigen::Vector3d cell = Eigen::Vector3d::Zero(), origin = Eigen::Vector3d(0.0, -1.0, -2.0);
  Eigen::Vector3d inverse = Eigen::Vector3d::Zero();  // 1 / cell
  std::array<int, 3> dims{0, 0, 0};

  static constexpr double kMaxCells = double(1 << 24);

  FeatureCells() = default;
  FeatureCells(Eigen::Vector3d c, double d_max) {
    const Eigen::Vector3d span(d_max, 2.0, 4.0);
    // Coarser cells when the table would be larger than kMaxCells (a tiny d cell).
    const double n = (span.array() / c.array() + 1.0).prod();
    if (n > kMaxCells) c *= std::cbrt(n / kMaxCells) * 1.01;
    cell = c;
    inverse = cell.cwiseInverse();
    for (int a = 0; a < 3; ++a) dims[a] = int(std::floor(span[a] * inverse[a])) + 1;
  }
  std::size_t size() const { return std::size_t(dims[0]) * std::size_t(dims[1]) * std::size_t(dims[2]); }
  std::size_t index(const float* f) const {
    std::size_t k = 0;
    for (int a = 0; a < 3; ++a) {
      const double x = std::floor((double(f[a]) - origin[a]) * inverse[a]);
      const int c = x < 0.0 ? 0 : x >= double(dims[a] - 1) ? dims[a] - 1 : int(x);
      k = k * std::size_t(dims[a]) + std::size_t(c);
    }
    return k;
  }
};

/// Whether the thinning keeps pair (i, j) of a cell of weight w: a hash of the pair, so that the
/// choice does not depend on the order or the threads of the build.
bool thinning_keeps(std::int32_t i, std::int32_t j, std::uint32_t w) {
  if (w <= 1) return true;
  std::uint64_t x = (std::uint64_t(std::uint32_t(i)) << 32) | std::uint32_t(j);
  x += 0x9e3779b97f4a7c15ull;  // splitmix64's finaliser
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  x ^= x >> 31;
  return ((x >> 32) * w) >> 32 == 0;  // the high word, uniform in [0, 2^32), scaled to [0, w)
}

/// The feature of (i, j) as stored (float32).
void stored_feature(const Points& points, const Points& normals, std::int32_t i, std::int32_t j, float* out) {
  double f[3];
  detail::pair_feature_raw(points.row(i).data(), normals.row(i).data(), points.row(j).data(), normals.row(j).data(), f);
  out[0] = float(f[0]), out[1] = float(f[1]), out[2] = float(f[2]);
}

struct Record {
  float f[3];
  std::int32_t i, j;
  std::int16_t g[4];  // pair_geometry() row
};

std::int16_t quantise(double v, double scale) {
  return static_cast<std::int16_t>(std::round(std::clamp(v, -1.0, 1.0) * scale));
}

double angle_of(double cosine) { return std::acos(std::clamp(cosine, -1.0, 1.0)); }

/// The pair_geometry() row of the oriented points (pi, ni), (pj, nj).
void pair_geometry_raw(const double* pi, const double* ni, const double* pj, const double* nj, std::int16_t* g) {
  constexpr double kPi = 3.14159265358979323846;
  const double as = PairIndex::kGeometryScale / kPi;  // angles in [0, pi]
  const Eigen::Vector3d a(ni[0], ni[1], ni[2]), b(nj[0], nj[1], nj[2]);
  const Eigen::Vector3d d(pj[0] - pi[0], pj[1] - pi[1], pj[2] - pi[2]);
  const double len = d.norm();
  g[0] = quantise(angle_of(a.dot(b)) / kPi, PairIndex::kGeometryScale);
  if (!(len > 0.0)) {
    g[1] = g[2] = g[3] = 0;
    return;
  }
  const Eigen::Vector3d u = d / len;
  g[1] = static_cast<std::int16_t>(std::round(angle_of(a.dot(u)) * as));
  g[2] = static_cast<std::int16_t>(std::round(angle_of(b.dot(u)) * as));
  g[3] = quantise(a.cross(b).dot(u), PairIndex::kGeometryScale);
}

/// The pair budget in force: max_pairs, at most what 32-bit pair indices can address.
std::size_t pair_limit(std::size_t max_pairs) {
  return std::min<std::size_t>(max_pairs, std::numeric_limits<std::uint32_t>::max());
}

/// PairIndex's refusal, with the counts build_target_index() needs to name an edge that fits.
class PairBudgetExceeded : public BudgetError {
 public:
  PairBudgetExceeded(const std::string& message, std::size_t facets, std::size_t pairs)
      : BudgetError(message), facets(facets), pairs(pairs) {}
  std::size_t facets, pairs;
};

constexpr double kFacetAreaPerEdge2 = 0.86602540378443865;  // unit facet area / edge^2 (tessellate)
constexpr double kFarOver = 1.5;  // estimated pairs over this times the budget: surely over it

/// What suggest_edge() and build_target_index() estimate from: the surface area taking part and
/// the fraction of facet pairs within d_max, measured on a coarse tessellation (about 1500 facets).
struct PairEstimate {
  double area = 0.0;
  double fraction = 1.0;
  /// Estimated stored pairs at facet edge `edge` (metres).
  double pairs(double edge) const {
    const double n = area / (kFacetAreaPerEdge2 * edge * edge);
    return fraction * 0.5 * n * n;
  }
};

// The surface area taking part in the estimate (m^2). Throws for a mesh without any.
double estimate_area(const Mesh& mesh) {
  double area = 0.0;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    if (mesh.faces.row(f).minCoeff() < 0 || mesh.faces.row(f).maxCoeff() >= mesh.vertices.rows()) continue;
    const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, 0)).transpose();
    const Eigen::Vector3d b = mesh.vertices.row(mesh.faces(f, 1)).transpose();
    const Eigen::Vector3d c = mesh.vertices.row(mesh.faces(f, 2)).transpose();
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  if (!(area > 0.0) || !std::isfinite(area)) throw std::invalid_argument("mesh: has no surface area");
  return area;
}

PairEstimate estimate_pairs(const Mesh& mesh, double d_max, const Mask& free_faces) {
  PairEstimate e;
  e.area = estimate_area(mesh);
  const double coarse_edge = std::sqrt(e.area / (kFacetAreaPerEdge2 * 1500.0));
  const UnitFacets coarse = tessellate(mesh, coarse_edge, free_faces);
  const double n = double(coarse.points.rows());
  // At least one pair, so that a d_max below the coarse spacing still gives a finite estimate.
  const double coarse_pairs = std::max(1.0, double(count_pairs(coarse.points, d_max, coarse.free)));
  e.fraction = coarse_pairs / (0.5 * n * n);
  return e;
}

// `kept` (when not null): the tessellation at the edge returned.
double suggest_edge_from(const Mesh& mesh, double d_max, std::size_t max_pairs, const Mask& free_faces,
                         const PairEstimate& est, std::optional<UnitFacets>* kept = nullptr) {
  const double n_fit = std::max(1.0, std::sqrt(2.0 * double(max_pairs) / est.fraction));
  double edge = std::sqrt(est.area / (kFacetAreaPerEdge2 * n_fit));
  // Check and refine: the pair count scales about as edge^-4. Keep the finest edge that fits.
  double best = std::numeric_limits<double>::infinity();
  for (int iter = 0; iter < 12; ++iter) {
    UnitFacets f = tessellate(mesh, edge, free_faces);
    const double pairs = double(count_pairs(f.points, d_max, f.free));
    if (pairs <= double(max_pairs)) {
      if (edge < best && kept) *kept = std::move(f);
      best = std::min(best, edge);
      if (pairs >= 0.95 * double(max_pairs)) break;
    }
    const double next = pairs > 0.0 ? edge * std::pow(pairs / (0.975 * double(max_pairs)), 0.25) : 0.5 * edge;
    if (next >= best) break;  // would only coarsen past an edge that already fits
    edge = next;
  }
  if (!std::isfinite(best))
    throw std::invalid_argument("max_pairs: found no facet edge whose pairs fit a budget of " +
                                std::to_string(max_pairs) + " pairs");
  return best;
}

}  // namespace

// ====================================================================== PairIndex::Impl
struct PairIndex::Impl {
  Points points, normals;
  Mask free;
  double d_max = 0.0;
  double spacing = 0.0;
  std::size_t found = 0;              // pairs before thinning
  std::size_t max_per_cell = 0;       // 0: no thinning
  FeatureCells cells;                 // the thinning's cells (when max_per_cell > 0)
  std::vector<std::uint16_t> weights; // per cell (when max_per_cell > 0)
  Eigen::Matrix<std::int32_t, Eigen::Dynamic, 2, Eigen::RowMajor> pairs;
  Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> features;
  Eigen::Matrix<std::int16_t, Eigen::Dynamic, 4, Eigen::RowMajor> geometry;
  std::vector<float> boxes;  // 6 per node, heap order
  int depth = 0;

  void build_tree(std::vector<Record>& rec, int threads);
  // Walks the tree for the box |f - center| <= tolerance: whole(b, e) for a subtree wholly inside,
  // one(k) for each single stored pair inside, in increasing index order.
  template <class Whole, class One>
  void walk(const Eigen::Vector3d& center, const Eigen::Vector3d& tolerance, Whole whole, One one) const;
};

void PairIndex::Impl::build_tree(std::vector<Record>& rec, int threads) {
  const std::size_t m = rec.size();
  depth = 0;
  while ((m >> (depth + 1)) >= std::size_t(kLeafSize)) ++depth;
  const std::size_t nodes = (std::size_t(2) << depth) - 1;
  boxes.assign(6 * nodes, 0.0f);
  if (m == 0) return;

  auto box_of = [&](std::size_t b, std::size_t e, float* out) {
    float lo[3] = {rec[b].f[0], rec[b].f[1], rec[b].f[2]}, hi[3] = {lo[0], lo[1], lo[2]};
    for (std::size_t k = b + 1; k < e; ++k)
      for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], rec[k].f[a]), hi[a] = std::max(hi[a], rec[k].f[a]);
    for (int a = 0; a < 3; ++a) out[a] = lo[a], out[3 + a] = hi[a];
  };
  box_of(0, m, &boxes[0]);
  double scale[3];
  for (int a = 0; a < 3; ++a) {
    const double ext = double(boxes[3 + a]) - double(boxes[a]);
    scale[a] = ext > 0.0 ? 1.0 / ext : 0.0;
  }
  int parallel_depth = 0;
  while ((1 << (parallel_depth + 1)) <= threads && parallel_depth < depth) ++parallel_depth;

  // Recursive median split; the box of `node` is already set.
  std::function<void(std::size_t, std::size_t, std::size_t, int)> split = [&](std::size_t node, std::size_t b,
                                                                              std::size_t e, int level) {
    if (level == depth) return;
    const float* bx = &boxes[6 * node];
    int axis = 0;
    double best = -1.0;
    for (int a = 0; a < 3; ++a) {
      const double ext = (double(bx[3 + a]) - double(bx[a])) * scale[a];
      if (ext > best) best = ext, axis = a;
    }
    const std::size_t mid = b + (e - b) / 2;
    auto select = [&](auto axis_constant) {
      constexpr int A = decltype(axis_constant)::value;
      std::nth_element(rec.begin() + b, rec.begin() + mid, rec.begin() + e,
                       [](const Record& x, const Record& y) { return x.f[A] < y.f[A]; });
    };
    if (axis == 0)
      select(std::integral_constant<int, 0>());
    else if (axis == 1)
      select(std::integral_constant<int, 1>());
    else
      select(std::integral_constant<int, 2>());
    const std::size_t l = 2 * node + 1, r = 2 * node + 2;
    auto left = [&, l, b, mid, level] {
      box_of(b, mid, &boxes[6 * l]);
      split(l, b, mid, level + 1);
    };
    auto right = [&, r, mid, e, level] {
      box_of(mid, e, &boxes[6 * r]);
      split(r, mid, e, level + 1);
    };
    if (level < parallel_depth) {
      detail::parallel_for(2, 2, [&](std::size_t k) { k == 0 ? left() : right(); });
    } else {
      left();
      right();
    }
  };
  split(0, 0, m, 0);
}

PairIndex::PairIndex(const Points& points, const Points& normals, const Mask& free,
                     const PairIndexOptions& options) {
  detail::check_size("normals: rows", points.rows(), normals.rows());
  if (free.size() != 0) detail::check_size("free: size", points.rows(), free.size());
  check_d_max(options.d_max);
  if (!(options.max_normal_dot >= -1.0 && options.max_normal_dot <= 1.0))
    throw std::invalid_argument("max_normal_dot: expected a number in [-1, 1], got " + fmt(options.max_normal_dot));
  const Eigen::Vector3d& cell = options.cell;
  if (!cell.allFinite() || !(cell.isZero() || (cell.array() > 0.0).all()))
    throw std::invalid_argument("cell: expected three positive finite sizes (d metres, n_i.n_j, beta) or zeros, got (" +
                                fmt(cell[0]) + ", " + fmt(cell[1]) + ", " + fmt(cell[2]) + ")");
  if (points.rows() > std::numeric_limits<std::int32_t>::max())
    throw std::invalid_argument("points: more than 2^31 - 1 rows");
  check_points("points", points);
  check_normals(normals);
  const int threads = detail::resolve_threads(options.threads, std::size_t(points.rows()) / 256 + 1);

  auto impl = std::make_shared<Impl>();
  impl->points = points;
  impl->normals = normals;
  impl->free = free;
  impl->d_max = options.d_max;

  // Count first: refuse before storing anything.
  const PairGrid g = make_pair_grid(points, free, options.d_max);
  const NormalFilter keep{options.max_normal_dot < 1.0 ? &normals : nullptr, options.max_normal_dot};
  impl->spacing = median_nn_spacing(points, threads);
  const std::vector<std::size_t> counts = count_per_point(points, g, options.d_max, threads, keep);
  std::size_t m = 0;
  for (auto c : counts) m += c;
  impl->found = m;
  const std::size_t limit = pair_limit(options.max_pairs);
  if (m > limit) {
    const double n = double(g.active.size());
    const double ratio = double(m) / double(std::max<std::size_t>(limit, 1));
    const long long fit = static_cast<long long>(std::floor(n / std::sqrt(ratio)));
    std::ostringstream msg;
    msg << "max_pairs: " << g.active.size() << (free.size() ? " free" : "") << " facets give " << m
        << " pairs with d <= d_max = " << fmt(options.d_max) << " m, more than the budget of " << limit
        << " pairs; about " << fit << " facets would fit (pairs grow as facets^2: coarsen the facet edge by x"
        << fmt(std::pow(ratio, 0.25), 3) << " = (pairs/budget)^(1/4), or raise max_pairs)";
    throw PairBudgetExceeded(msg.str(), g.active.size(), m);
  }

  // Thinning: each feature cell's weight w from its pairs (counted on every `stride`-th point's
  // pairs when there are many: any w keeps the weighted sum unbiased, since a pair of a cell of
  // weight w is kept with probability 1 / w), then the pairs kept.
  const bool thin = options.max_pairs_per_cell > 0 && m > 0;
  if (thin) {
    impl->max_per_cell = options.max_pairs_per_cell;
    const double h = impl->spacing > 0.0 && std::isfinite(impl->spacing) ? impl->spacing : options.d_max / 10;
    impl->cells = FeatureCells(options.cell.isZero() ? Eigen::Vector3d(0.5 * h, 0.1, 0.1) : options.cell, options.d_max);
    const std::size_t stride = std::clamp<std::size_t>(m / kHistogramPairs, 1, 64);
    std::vector<std::vector<std::uint32_t>> hist(static_cast<std::size_t>(threads));
    detail::parallel_chunks(g.active.size(), threads, [&](std::size_t b, std::size_t e, int t) {
      auto& hc = hist[std::size_t(t)];
      hc.assign(impl->cells.size(), 0);
      for (std::size_t k = (b + stride - 1) / stride * stride; k < e; k += stride)
        visit_pairs(points, g, options.d_max, k, k + 1, [&](std::int32_t i, std::int32_t j) {
          if (!keep(i, j)) return;
          float f[3];
          stored_feature(points, normals, i, j, f);
          ++hc[impl->cells.index(f)];
        });
    });
    impl->weights.assign(impl->cells.size(), 1);
    const std::size_t cap = options.max_pairs_per_cell;
    for (std::size_t c = 0; c < impl->cells.size(); ++c) {
      std::size_t n = 0;
      for (const auto& hc : hist)
        if (!hc.empty()) n += hc[c];
      n *= stride;
      if (n > cap) impl->weights[c] = std::uint16_t(std::min<std::size_t>(65535, (n + cap - 1) / cap));
    }
  }
  // The record of pair (i, j) when it is stored.
  auto make = [&](std::int32_t i, std::int32_t j, Record& r) {
    if (!keep(i, j)) return false;
    stored_feature(points, normals, i, j, r.f);
    if (thin && !thinning_keeps(i, j, impl->weights[impl->cells.index(r.f)])) return false;
    r.i = i, r.j = j;
    pair_geometry_raw(points.row(i).data(), normals.row(i).data(), points.row(j).data(), normals.row(j).data(), r.g);
    return true;
  };

  std::vector<Record> rec;
  if (!thin) {  // every pair counted: each point's records go to their place
    std::vector<std::size_t> offset(counts.size() + 1, 0);
    for (std::size_t k = 0; k < counts.size(); ++k) offset[k + 1] = offset[k] + counts[k];
    rec.resize(m);
    detail::parallel_chunks(g.active.size(), threads, [&](std::size_t b, std::size_t e, int) {
      for (std::size_t k = b; k < e; ++k) {
        std::size_t at = offset[k];
        visit_pairs(points, g, options.d_max, k, k + 1, [&](std::int32_t i, std::int32_t j) {
          if (make(i, j, rec[at])) ++at;
        });
      }
    });
  } else {  // the kept pairs per chunk of points, joined in point order
    std::vector<std::vector<Record>> part(static_cast<std::size_t>(threads));
    detail::parallel_chunks(g.active.size(), threads, [&](std::size_t b, std::size_t e, int t) {
      auto& out = part[std::size_t(t)];
      Record r;
      visit_pairs(points, g, options.d_max, b, e, [&](std::int32_t i, std::int32_t j) {
        if (make(i, j, r)) out.push_back(r);
      });
    });
    std::size_t n = 0;
    for (const auto& p : part) n += p.size();
    rec.reserve(n);
    for (auto& p : part) {
      rec.insert(rec.end(), p.begin(), p.end());
      std::vector<Record>().swap(p);
    }
    m = rec.size();
  }

  impl->build_tree(rec, threads);
  impl->pairs.resize(Eigen::Index(m), 2);
  impl->features.resize(Eigen::Index(m), 3);
  impl->geometry.resize(Eigen::Index(m), 4);
  detail::parallel_chunks(m, threads, [&](std::size_t b, std::size_t e, int) {
    for (std::size_t k = b; k < e; ++k) {
      impl->pairs(k, 0) = rec[k].i, impl->pairs(k, 1) = rec[k].j;
      for (int a = 0; a < 3; ++a) impl->features(k, a) = rec[k].f[a];
      for (int a = 0; a < 4; ++a) impl->geometry(k, a) = rec[k].g[a];
    }
  });
  std::vector<Record>().swap(rec);
  impl_ = std::move(impl);
}

std::size_t PairIndex::size() const { return std::size_t(impl_->pairs.rows()); }
std::size_t PairIndex::pairs_found() const { return impl_->found; }
std::uint32_t PairIndex::weight(std::size_t k) const {
  const Impl& s = *impl_;
  if (k >= std::size_t(s.pairs.rows()))
    throw std::out_of_range("weight: pair " + std::to_string(k) + " of " + std::to_string(s.pairs.rows()));
  if (s.weights.empty()) return 1;
  return s.weights[s.cells.index(s.features.data() + 3 * k)];
}
Eigen::Vector3d PairIndex::thin_cell() const {
  return impl_->max_per_cell ? impl_->cells.cell : Eigen::Vector3d::Zero();
}
std::size_t PairIndex::max_pairs_per_cell() const { return impl_->max_per_cell; }
const Eigen::Matrix<std::int32_t, Eigen::Dynamic, 2, Eigen::RowMajor>& PairIndex::pairs() const {
  return impl_->pairs;
}
const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>& PairIndex::features() const {
  return impl_->features;
}
const Eigen::Matrix<std::int16_t, Eigen::Dynamic, 4, Eigen::RowMajor>& PairIndex::pair_geometry() const {
  return impl_->geometry;
}
const Points& PairIndex::points() const { return impl_->points; }
const Points& PairIndex::normals() const { return impl_->normals; }
const Mask& PairIndex::free() const { return impl_->free; }
double PairIndex::d_max() const { return impl_->d_max; }
double PairIndex::spacing() const { return impl_->spacing; }
int PairIndex::depth() const { return impl_->depth; }
const std::vector<float>& PairIndex::node_boxes() const { return impl_->boxes; }

std::size_t PairIndex::nbytes() const {
  const Impl& s = *impl_;
  return sizeof(Impl) + std::size_t(s.pairs.size()) * sizeof(std::int32_t) +
         std::size_t(s.features.size()) * sizeof(float) + std::size_t(s.geometry.size()) * sizeof(std::int16_t) +
         s.boxes.size() * sizeof(float) + s.weights.size() * sizeof(std::uint16_t) +
         std::size_t(s.points.size() + s.normals.size()) * sizeof(double) + std::size_t(s.free.size());
}

namespace {

void check_box(const Eigen::Vector3d& center, const Eigen::Vector3d& tolerance) {
  if (!center.allFinite())
    throw std::invalid_argument("center: expected finite values, got (" + fmt(center[0]) + ", " +
                                fmt(center[1]) + ", " + fmt(center[2]) + ")");
  for (int a = 0; a < 3; ++a)
    if (!(tolerance[a] >= 0.0))
      throw std::invalid_argument("tolerance: expected non-negative values, got (" + fmt(tolerance[0]) + ", " +
                                  fmt(tolerance[1]) + ", " + fmt(tolerance[2]) + ")");
}

// The floats x with |double(x) - c| <= t (the brute-force test, in double): since double(x) - c
// grows with x, they form an interval [lo, hi] of floats (lo > hi: none). Found from the nearest
// floats to c -/+ t and stepped to the exact ends, so that every later test is a float comparison
// equal to the double one.
struct FloatRange {
  float lo, hi;
};
FloatRange float_range(double c, double t) {
  constexpr float inf = std::numeric_limits<float>::infinity();
  auto above_lo = [&](float x) { return double(x) - c >= -t; };
  auto below_hi = [&](float x) { return double(x) - c <= t; };
  auto to_float = [](double v) {
    return v < -double(std::numeric_limits<float>::max()) ? -std::numeric_limits<float>::max()
           : v > double(std::numeric_limits<float>::max()) ? std::numeric_limits<float>::max()
                                                           : static_cast<float>(v);
  };
  FloatRange r{to_float(c - t), to_float(c + t)};
  // Step down while the float below still passes, up while this one fails (a few steps at most;
  // the ends stop at the largest finite floats, and infinities pass or fail as the test says).
  while (r.lo > -inf && above_lo(std::nextafter(r.lo, -inf))) r.lo = std::nextafter(r.lo, -inf);
  while (r.lo < inf && !above_lo(r.lo)) r.lo = std::nextafter(r.lo, inf);
  while (r.hi < inf && below_hi(std::nextafter(r.hi, inf))) r.hi = std::nextafter(r.hi, inf);
  while (r.hi > -inf && !below_hi(r.hi)) r.hi = std::nextafter(r.hi, -inf);
  return r;
}
}  // namespace

template <class Whole, class One>
void PairIndex::Impl::walk(const Eigen::Vector3d& center, const Eigen::Vector3d& tolerance, Whole whole,
                           One one) const {
  const Impl& s = *this;
  const std::size_t m = std::size_t(s.pairs.rows());
  if (m == 0) return;
  FloatRange q[3];
  for (int a = 0; a < 3; ++a) {
    q[a] = float_range(center[a], tolerance[a]);
    if (q[a].lo > q[a].hi) return;  // no float passes
  }
  const float* feat = s.features.data();
  struct Item {
    std::uint32_t node, b, e;
    int level;
  };
  Item stack[72];
  int top = 0;
  stack[top++] = {0, 0, std::uint32_t(m), 0};
  while (top > 0) {
    const Item it = stack[--top];
    const float* bx = &s.boxes[6 * std::size_t(it.node)];
    bool disjoint = false, inside = true;
    for (int a = 0; a < 3; ++a) {
      const float lo = bx[a], hi = bx[3 + a];
      if (hi < q[a].lo || lo > q[a].hi) {
        disjoint = true;
        break;
      }
      inside = inside && lo >= q[a].lo && hi <= q[a].hi;
    }
    if (disjoint) continue;
    if (inside) {
      whole(it.b, it.e);
      continue;
    }
    if (it.level == s.depth) {
      for (std::uint32_t k = it.b; k < it.e; ++k) {
        const float* f = feat + 3 * std::size_t(k);
        if (f[0] >= q[0].lo && f[0] <= q[0].hi && f[1] >= q[1].lo && f[1] <= q[1].hi && f[2] >= q[2].lo &&
            f[2] <= q[2].hi)
          one(k);
      }
      continue;
    }
    const std::uint32_t mid = it.b + (it.e - it.b) / 2;
    stack[top++] = {2 * it.node + 2, mid, it.e, it.level + 1};
    stack[top++] = {2 * it.node + 1, it.b, mid, it.level + 1};
  }
}

void PairIndex::query(const Eigen::Vector3d& center, const Eigen::Vector3d& tolerance,
                      std::vector<std::uint32_t>& out) const {
  check_box(center, tolerance);
  impl_->walk(
      center, tolerance,
      [&](std::uint32_t b, std::uint32_t e) {
        for (std::uint32_t k = b; k < e; ++k) out.push_back(k);
      },
      [&](std::uint32_t k) { out.push_back(k); });
}

std::size_t PairIndex::count(const Eigen::Vector3d& center, const Eigen::Vector3d& tolerance) const {
  check_box(center, tolerance);
  std::size_t n = 0;
  impl_->walk(
      center, tolerance, [&](std::uint32_t b, std::uint32_t e) { n += e - b; },
      [&](std::uint32_t) { ++n; });
  return n;
}

std::vector<std::uint32_t> PairIndex::query(const Eigen::Vector3d& center, const Eigen::Vector3d& tolerance) const {
  std::vector<std::uint32_t> out;
  query(center, tolerance, out);
  return out;
}

// ====================================================================== free functions
std::size_t count_pairs(const Points& points, double d_max, const Mask& free, int threads) {
  if (free.size() != 0) detail::check_size("free: size", points.rows(), free.size());
  check_d_max(d_max);
  check_points("points", points);
  const PairGrid g = make_pair_grid(points, free, d_max);
  const auto counts =
      count_per_point(points, g, d_max, detail::resolve_threads(threads, g.active.size() / 256 + 1));
  std::size_t m = 0;
  for (auto c : counts) m += c;
  return m;
}

double suggest_edge(const Mesh& mesh, double d_max, std::size_t max_pairs, const Mask& free_faces, double min_edge) {
  return detail::suggest_edge(mesh, d_max, max_pairs, free_faces, min_edge, nullptr);
}

double detail::suggest_edge(const Mesh& mesh, double d_max, std::size_t max_pairs, const Mask& free_faces,
                            double min_edge, std::optional<UnitFacets>* facets) {
  check_d_max(d_max);
  if (max_pairs == 0) throw std::invalid_argument("max_pairs: expected at least 1, got 0");
  if (!std::isfinite(min_edge) || min_edge < 0.0)
    throw std::invalid_argument("min_edge: expected a finite length >= 0 (m), got " + fmt(min_edge));
  // The count at min_edge is skipped when even the coarse estimate is far over the budget (the
  // estimate is good to some per cent, as build_target_index() trusts it): on a large target that
  // count alone tessellated millions of facets and counted billions of pairs.
  const PairEstimate all{estimate_area(mesh), 1.0};
  std::optional<PairEstimate> est;
  if (min_edge > 0.0 && all.pairs(min_edge) > kFarOver * double(max_pairs)) est = estimate_pairs(mesh, d_max, free_faces);
  if (min_edge > 0.0 && !(est && est->pairs(min_edge) > kFarOver * double(max_pairs))) {
    UnitFacets f = tessellate(mesh, min_edge, free_faces);
    if (count_pairs(f.points, d_max, f.free) <= max_pairs) {
      if (facets) *facets = std::move(f);
      return min_edge;
    }
  }
  if (!est) est = estimate_pairs(mesh, d_max, free_faces);
  std::optional<UnitFacets> kept;
  const double best = suggest_edge_from(mesh, d_max, max_pairs, free_faces, *est, facets ? &kept : nullptr);
  if (best < min_edge) return min_edge;
  if (facets) *facets = std::move(kept);
  return best;
}

namespace {

void check_build_arguments(double edge, const PairIndexOptions& options) {
  check_d_max(options.d_max);
  if (options.max_pairs == 0) throw std::invalid_argument("max_pairs: expected at least 1, got 0");
  if (!std::isfinite(edge) || edge < 0.0)
    throw std::invalid_argument("edge: expected a positive facet edge in metres (0: suggested), got " + fmt(edge));
}

// The refusal of `edge`, naming an edge that fits with a little room (the count at an edge varies
// by a fraction of a per cent with the tessellation), rounded up.
BudgetError refusal(const Mesh& mesh, double edge, const Mask& free_faces, const PairIndexOptions& options,
                    const PairEstimate& est, const std::string& how_many) {
  const std::size_t limit = pair_limit(options.max_pairs);
  const double fit = suggest_edge_from(mesh, options.d_max, std::max<std::size_t>(1, limit / 50 * 49), free_faces, est);
  const double unit = std::pow(10.0, std::floor(std::log10(fit)) - 3);  // 4 significant digits
  std::ostringstream msg;
  msg << "max_pairs: at a facet edge of " << fmt(edge) << " m the target gives " << how_many
      << " pairs with d <= d_max = " << fmt(options.d_max) << " m, more than the budget of " << limit
      << " pairs; a facet edge of " << fmt(std::ceil(fit / unit) * unit, 4)
      << " m fits (pairs grow as edge^-4), or raise max_pairs";
  return BudgetError(msg.str());
}

// Far over the budget (the estimate is good to some per cent): refused before tessellating, whose
// facets alone could exhaust memory at a tiny edge.
void refuse_far_over(const Mesh& mesh, double edge, const Mask& free_faces, const PairIndexOptions& options,
                     const PairEstimate& est) {
  const double estimated = est.pairs(edge);
  if (estimated > kFarOver * double(pair_limit(options.max_pairs)))
    throw refusal(mesh, edge, free_faces, options, est, "about " + fmt(estimated, 3));
}

// refuse_far_over() at a given edge, with the coarse estimate only where it may refuse: the
// estimate's fraction of pairs is at most 1, so at most half the square of the facets the area
// makes at `edge` are estimated, and when that fits, so does the estimate.
void refuse_far_over(const Mesh& mesh, double edge, const Mask& free_faces, const PairIndexOptions& options) {
  const PairEstimate all{estimate_area(mesh), 1.0};
  if (all.pairs(edge) > kFarOver * double(pair_limit(options.max_pairs)))
    refuse_far_over(mesh, edge, free_faces, options, estimate_pairs(mesh, options.d_max, free_faces));
}

}  // namespace

void check_pair_estimate(const Mesh& mesh, double edge, const Mask& free_faces, const PairIndexOptions& options) {
  check_build_arguments(edge, options);
  if (edge > 0.0) refuse_far_over(mesh, edge, free_faces, options);
}

TargetIndex build_target_index(const Mesh& mesh, double edge, const Mask& free_faces,
                               const PairIndexOptions& options) {
  return detail::build_target_index(mesh, edge, free_faces, options, std::nullopt);
}

TargetIndex detail::build_target_index(const Mesh& mesh, double edge, const Mask& free_faces,
                                       const PairIndexOptions& options, std::optional<UnitFacets> given) {
  check_build_arguments(edge, options);
  if (edge == 0.0) {
    edge = suggest_edge_from(mesh, options.d_max, pair_limit(options.max_pairs), free_faces,
                             estimate_pairs(mesh, options.d_max, free_faces));
    given.reset();  // made at another edge
  }
  refuse_far_over(mesh, edge, free_faces, options);
  UnitFacets facets = given ? std::move(*given) : tessellate(mesh, edge, free_faces);
  try {
    PairIndex index(facets.points, facets.normals, facets.free, options);
    return TargetIndex{std::move(facets), std::move(index)};
  } catch (const PairBudgetExceeded& e) {
    throw refusal(mesh, edge, free_faces, options, estimate_pairs(mesh, options.d_max, free_faces),
                  std::to_string(e.facets) + (free_faces.size() ? " free" : "") + " unit facets and " +
                      std::to_string(e.pairs));
  }
}

}  // namespace pairgrasp
