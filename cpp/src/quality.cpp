#include <pairgrasp/quality.hpp>

#include "convex_hull.hpp"

#include <Eigen/LU>
#include <Eigen/SVD>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

namespace pairgrasp {

namespace {

// Relative tolerance on singular values and on the origin's facet distance: a wrench set whose
// smallest singular value is below kRtol times its largest is rank-deficient, and an origin closer
// than kRtol times the largest wrench norm to a facet counts as on the boundary. Since epsilon never
// exceeds the smallest singular value, both tests declare the same near-degenerate grasps non-closure.
constexpr double kRtol = 1e-9;
// qhull options: SciPy's ConvexHull defaults ("Qt", plus "Qx" above 4-D), then joggled input.
constexpr const char* kHullOptions = "Qt Qx";
constexpr const char* kJoggleOptions = "QJ Qt";
// Contacts whose wrenches make the active set's first hull. Growing the set by single wrenches
// from there (not by whole contacts) keeps its hulls small: over the contact sets of the demo plan
// a start of 4 contacts (32 wrenches with 8 pyramid edges) scored 1.6-1.8x faster than 7 contacts
// grown contact by contact (the search's reduced sets and the final grasps' full ones alike), with
// the same epsilon; starts of 2, 3, 5 and 10 contacts were slower.
constexpr int kActiveSetStart = 4;

using Matrix = Eigen::MatrixXd;

/// The distinct rows of `w`, in lexicographic order (-0.0 equals 0.0).
Matrix unique_rows(const Eigen::Ref<const Matrix>& w) {
  std::vector<Eigen::Index> order(w.rows());
  std::iota(order.begin(), order.end(), Eigen::Index{0});
  auto less = [&](Eigen::Index a, Eigen::Index b) {
    for (Eigen::Index c = 0; c < w.cols(); ++c)
      if (w(a, c) != w(b, c)) return w(a, c) < w(b, c);
    return false;
  };
  std::sort(order.begin(), order.end(), less);
  std::vector<Eigen::Index> keep;
  for (Eigen::Index i : order)
    if (keep.empty() || less(keep.back(), i)) keep.push_back(i);
  Matrix u(static_cast<Eigen::Index>(keep.size()), w.cols());
  for (std::size_t k = 0; k < keep.size(); ++k) u.row(static_cast<Eigen::Index>(k)) = w.row(keep[k]);
  return u;
}

int count_above(const Eigen::VectorXd& values, double tol) {
  return static_cast<int>((values.array() > tol).count());
}

/// min over directions (the columns of `dirs` and their negatives) of the support max_w d.w.
double support_minimum(const Eigen::Ref<const Matrix>& w, const Matrix& dirs) {
  const Matrix proj = w * dirs;
  double best = std::numeric_limits<double>::infinity();
  for (Eigen::Index k = 0; k < proj.cols(); ++k)
    best = std::min({best, proj.col(k).maxCoeff(), -proj.col(k).minCoeff()});
  return best;
}

/// The bound of epsilon_upper_bound() given the right singular vectors `v` of `w`.
double support_bound(const Eigen::Ref<const Matrix>& w, const Matrix& v) {
  return std::max(0.0, std::min(support_minimum(w, Matrix::Identity(6, 6)), support_minimum(w, v)));
}

/// A tighter upper bound of epsilon than support_bound(), still without a hull: every unit u
/// bounds epsilon by the support h(u) = max_w w.u (a ball about the origin inside the hull stays on
/// the inner side of that support plane), so normalised subgradient steps down h on the unit
/// sphere, from the best of the directions `dirs` (columns) and their negatives, keep the least
/// value met.
double descent_bound(const Eigen::Ref<const Matrix>& w, const Matrix& dirs, int iterations = 60) {
  Eigen::VectorXd u = dirs.col(0);
  double best = std::numeric_limits<double>::infinity();
  for (Eigen::Index k = 0; k < dirs.cols(); ++k)
    for (double sign : {1.0, -1.0}) {
      const double h = (w * (sign * dirs.col(k))).maxCoeff();
      if (h < best) best = h, u = sign * dirs.col(k);
    }
  double step = 0.25;
  for (int it = 0; it < iterations && best > 0.0; ++it) {
    Eigen::Index top = 0;
    const double h = (w * u).maxCoeff(&top);
    if (h < best) best = h;
    Eigen::VectorXd g = w.row(top).transpose();
    g -= g.dot(u) * u;  // the subgradient's part along the sphere
    const double gn = g.norm();
    if (gn <= 1e-15 * w.row(top).norm()) break;  // u is the support row's own direction
    u = (u - step * best / gn * g).normalized();
    step *= 0.9;
  }
  return std::max(best, 0.0);
}

/// Where the origin lies against conv(w), without a hull, by Wolfe's minimum-norm-point algorithm
/// (finite, exact in exact arithmetic). Each verdict is then checked on its own certificate:
/// - `separated`: the minimum-norm point x has min_w w.x > boundary_tol |x| (not force-closure);
/// - `inner` > 0: the run ended on a simplex of 7 wrenches that holds the origin, with every
///   barycentric coordinate lambda_i positive; the origin's distance to the simplex's facets,
///   min_i lambda_i / |grad lambda_i|, bounds epsilon from below (the simplex lies in the hull), so
///   the grasp is force-closure.
/// Neither (origin on or within rounding of the boundary, or a degenerate simplex): unknown.
struct OriginInHull {
  bool separated = false;
  double inner = 0.0;
};

/// The point of conv(w) nearest to the origin by Wolfe's algorithm: `x`, and the rows `set` with
/// positive weights `lambda` whose combination it is. `ok` false when a step's system was singular.
struct MinNormPoint {
  Eigen::VectorXd x;
  std::vector<Eigen::Index> set;
  std::vector<double> lambda;
  bool ok = true;
};

MinNormPoint min_norm_point(const Eigen::Ref<const Matrix>& w, int iterations = 200) {
  using Vec = Eigen::VectorXd;
  const Eigen::Index dim = w.cols();
  Eigen::Index first = 0;
  w.rowwise().squaredNorm().minCoeff(&first);
  MinNormPoint r;
  std::vector<Eigen::Index>& set = r.set;
  std::vector<double>& lambda = r.lambda;
  set.assign(1, first);
  lambda.assign(1, 1.0);
  Vec& x = r.x;
  x = w.row(first).transpose();
  const double scale = w.rowwise().squaredNorm().maxCoeff();
  for (int major = 0; major < iterations; ++major) {
    Eigen::Index j = 0;
    const double low = (w * x).minCoeff(&j);
    if (low > x.squaredNorm() - 1e-12 * scale) break;  // x is the minimum-norm point
    if (std::find(set.begin(), set.end(), j) != set.end() || static_cast<Eigen::Index>(set.size()) > dim) break;
    set.push_back(j);
    lambda.push_back(0.0);
    for (int minor = 0; minor <= dim + 1; ++minor) {
      // The affine minimum-norm point of the set: min |P mu|^2 with sum mu = 1.
      const auto m = static_cast<Eigen::Index>(set.size());
      Matrix p(dim, m);
      for (Eigen::Index k = 0; k < m; ++k) p.col(k) = w.row(set[k]).transpose();
      Matrix kkt = Matrix::Zero(m + 1, m + 1);
      kkt.topLeftCorner(m, m) = p.transpose() * p;
      kkt.topRightCorner(m, 1).setOnes();
      kkt.bottomLeftCorner(1, m).setOnes();
      Vec rhs = Vec::Zero(m + 1);
      rhs[m] = 1.0;
      const Vec mu = kkt.fullPivLu().solve(rhs).head(m);
      if (!mu.allFinite()) {
        r.ok = false;
        return r;
      }
      if ((mu.array() > 0.0).all()) {
        for (Eigen::Index k = 0; k < m; ++k) lambda[k] = mu[k];
        x = p * mu;
        break;
      }
      // Step from lambda towards mu until a weight reaches 0, and drop the points that did.
      double theta = 1.0;
      for (Eigen::Index k = 0; k < m; ++k)
        if (mu[k] <= 0.0 && lambda[k] - mu[k] > 0.0) theta = std::min(theta, lambda[k] / (lambda[k] - mu[k]));
      std::vector<Eigen::Index> kept_set;
      std::vector<double> kept_lambda;
      for (Eigen::Index k = 0; k < m; ++k) {
        const double l = theta * mu[k] + (1.0 - theta) * lambda[k];
        if (l > 1e-15) kept_set.push_back(set[k]), kept_lambda.push_back(l);
      }
      if (kept_set.empty()) {
        r.ok = false;
        return r;
      }
      set = std::move(kept_set);
      lambda = std::move(kept_lambda);
      x.setZero();
      for (std::size_t k = 0; k < set.size(); ++k) x += lambda[k] * w.row(set[k]).transpose();
    }
  }
  return r;
}

OriginInHull locate_origin(const Eigen::Ref<const Matrix>& w, double boundary_tol, int iterations = 200) {
  const Eigen::Index dim = w.cols();
  const MinNormPoint mnp = min_norm_point(w, iterations);
  if (!mnp.ok) return {};
  const Eigen::VectorXd& x = mnp.x;
  const std::vector<Eigen::Index>& set = mnp.set;
  OriginInHull out;
  const double xn = x.norm();
  if (xn > 0.0 && (w * x).minCoeff() > boundary_tol * xn) {
    out.separated = true;
    return out;
  }
  if (static_cast<Eigen::Index>(set.size()) != dim + 1) return out;
  // The certificate: barycentric coordinates of the origin in the simplex, and their gradients.
  Matrix a(dim + 1, dim + 1);
  for (Eigen::Index k = 0; k <= dim; ++k) {
    a.block(0, k, dim, 1) = w.row(set[static_cast<std::size_t>(k)]).transpose();
    a(dim, k) = 1.0;
  }
  const Eigen::FullPivLU<Matrix> lu(a);
  if (!lu.isInvertible()) return out;
  const Matrix inv = lu.inverse();  // lambda(y) = inv * [y; 1]
  double bound = std::numeric_limits<double>::infinity();
  for (Eigen::Index k = 0; k <= dim; ++k) {
    const double g = inv.row(k).head(dim).norm();
    const double l = inv(k, dim);
    if (!(l > 0.0) || !(g > 0.0)) return out;
    bound = std::min(bound, l / g);
  }
  if (bound > boundary_tol) out.inner = bound;
  return out;
}

/// The hull of a wrench set: epsilon, volume, the reason it is not force-closure ("" when it
/// is) and its facet planes (empty when there is no 6-D hull).
struct HullQuality {
  double epsilon = 0.0;
  double volume = 0.0;
  std::string reason;
  Matrix planes;  // (F, 7): unit outward normal a and offset b, a.x + b <= 0 inside
};

std::string origin_reason(double distance, double boundary_tol) {
  return std::string("the origin is ") + (distance < -boundary_tol ? "outside" : "on the boundary of") +
         " the wrench hull";
}

/// `joggle`: qhull's joggled input first (about twice as fast in 6-D; epsilon within ~1e-9 relative).
HullQuality hull_quality(const Eigen::Ref<const Matrix>& wrenches, double tol, double boundary_tol, bool volume,
                         bool joggle = false) {
  HullQuality out;
  const Matrix u = unique_rows(wrenches);  // frictionless edges coincide exactly
  if (u.rows() < 7) {
    out.reason = "only " + std::to_string(u.rows()) +
                 " distinct wrenches: the origin cannot be inside a 6-D hull of fewer than 7 points";
    return out;
  }
  const Matrix centred = u.rowwise() - u.colwise().mean();
  const int affine_rank = count_above(Eigen::JacobiSVD<Matrix>(centred).singularValues(), tol);
  if (affine_rank < 6) {
    out.reason = "the wrenches lie in a " + std::to_string(affine_rank) +
                 "-D affine subspace that misses the origin";
    return out;
  }
  // Nearly coplanar wrenches (contacts a rounding error off a pad's edge) can make qhull's final
  // precision check fail on a full-rank hull; joggled input (random moves of about 1e-11 of the
  // coordinates, qhull's fixed seed) has no such facets and changes epsilon by as little.
  using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const RowMatrix rows = u;
  detail::ConvexHull hull;
  std::string error;
  const int n = static_cast<int>(rows.rows());
  const char* first = joggle ? kJoggleOptions : kHullOptions;
  const char* second = joggle ? kHullOptions : kJoggleOptions;
  if (!detail::convex_hull(rows.data(), n, 6, first, volume, hull, error) &&
      !detail::convex_hull(rows.data(), n, 6, second, volume, hull, error)) {
    out.reason = "degenerate wrench hull (qhull: " + error + ")";  // numerically flat despite the rank tests
    return out;
  }
  out.volume = hull.volume;
  out.planes = std::move(hull.planes);
  const double distance = -out.planes.col(6).maxCoeff();
  if (distance > boundary_tol)
    out.epsilon = distance;
  else
    out.reason = origin_reason(distance, boundary_tol);
  return out;
}

/// Indices of the contacts to keep (ascending): for each group of contacts whose inward normals
/// are equal bit for bit, the vertices of the convex hull of the group's points (in the group's
/// affine span); the others' wrenches are convex combinations of the kept ones'.
std::vector<Eigen::Index> group_hull_vertices(const Points& p, const Points& n_in) {
  std::map<std::array<unsigned char, 24>, std::vector<Eigen::Index>> groups;
  for (Eigen::Index i = 0; i < p.rows(); ++i) {
    std::array<unsigned char, 24> key;
    const double v[3] = {n_in(i, 0), n_in(i, 1), n_in(i, 2)};
    std::memcpy(key.data(), v, sizeof v);
    groups[key].push_back(i);
  }
  std::vector<Eigen::Index> keep;
  for (const auto& entry : groups) {
    const std::vector<Eigen::Index>& idx = entry.second;
    const auto m = static_cast<Eigen::Index>(idx.size());
    if (m <= 2) {
      keep.insert(keep.end(), idx.begin(), idx.end());
      continue;
    }
    Matrix q(m, 3);
    for (Eigen::Index k = 0; k < m; ++k) q.row(k) = p.row(idx[k]);
    q = q.rowwise() - q.colwise().mean();
    Eigen::JacobiSVD<Matrix> svd(q, Eigen::ComputeThinV);
    const Eigen::VectorXd& sv = svd.singularValues();
    const int dim = count_above(sv, 1e-9 * std::max(sv(0), 1e-300));
    if (dim == 0) {  // every point the same
      keep.push_back(idx[0]);
      continue;
    }
    using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    const RowMatrix y = q * svd.matrixV().leftCols(dim);
    if (dim == 1) {
      Eigen::Index lo = 0, hi = 0;
      y.col(0).minCoeff(&lo);
      y.col(0).maxCoeff(&hi);
      keep.push_back(idx[lo]);
      keep.push_back(idx[hi]);
      continue;
    }
    detail::ConvexHull hull;
    std::string error;
    if (detail::convex_hull(y.data(), static_cast<int>(m), dim, "Qt", false, hull, error)) {
      for (int v : hull.vertices) keep.push_back(idx[v]);
    } else {  // numerically flatter than the SVD said: keep all
      keep.insert(keep.end(), idx.begin(), idx.end());
    }
  }
  std::sort(keep.begin(), keep.end());
  keep.erase(std::unique(keep.begin(), keep.end()), keep.end());
  return keep;
}

/// `count` contacts spread by farthest-point sampling over the rows of `coords`, from row 0 (ties:
/// the first farthest). An index repeats when fewer than `count` rows are distinct.
std::vector<Eigen::Index> spread_contacts(const Matrix& coords, Eigen::Index count) {
  std::vector<Eigen::Index> out{0};
  Eigen::VectorXd dist = (coords.rowwise() - coords.row(0)).rowwise().norm();
  while (static_cast<Eigen::Index>(out.size()) < count) {
    Eigen::Index k = 0;
    for (Eigen::Index i = 1; i < dist.size(); ++i)
      if (dist[i] > dist[k]) k = i;
    out.push_back(k);
    dist = dist.cwiseMin((coords.rowwise() - coords.row(k)).rowwise().norm());
  }
  return out;
}

/// Epsilon from hulls of growing subsets S of the contacts (the header's reduction 2). `w` holds
/// `per` rows per contact; `coords` (contacts, 6) = (point / radius, normal) spreads the start.
struct ActiveSetQuality {
  double epsilon = 0.0, volume = 0.0;
  std::string reason;
  bool exact = false;
  double upper = std::numeric_limits<double>::infinity();  ///< epsilon <= upper
  bool below = false;  ///< stopped with upper < `below`: epsilon is then only a lower bound
};

/// `until_closed`: stop at the first subset whose hull holds the origin (force closure proven, its
/// epsilon a lower bound; `exact` false). `below` > 0: epsilon is wanted only when it reaches
/// `below`; once a subset's facets bound it below that, the search stops, at once when `closed`
/// (force closure known) or a subset's hull holds the origin, else as `until_closed`.
ActiveSetQuality active_set_quality(const Matrix& w, Eigen::Index per, const Matrix& coords, double tol, bool volume,
                                    double boundary_tol, bool joggle, bool until_closed = false, double below = 0.0,
                                    bool closed = false) {
  const Eigen::Index n = coords.rows();
  if (n == 0) return {0.0, 0.0, "no contacts", true};
  // The set is kept per wrench row: it starts with every wrench of a few spread contacts and then
  // grows by the single wrenches that reach beyond its facets.
  std::vector<char> in_set(static_cast<std::size_t>(n * per), 0);
  auto add_contact = [&](Eigen::Index c) {
    for (Eigen::Index r = 0; r < per; ++r) in_set[static_cast<std::size_t>(c * per + r)] = 1;
  };
  auto contact_in_set = [&](Eigen::Index c) {
    for (Eigen::Index r = 0; r < per; ++r)
      if (in_set[static_cast<std::size_t>(c * per + r)]) return true;
    return false;
  };
  auto distance_to_set = [&](Eigen::Index i) {
    double best = std::numeric_limits<double>::infinity();
    for (Eigen::Index k = 0; k < n; ++k)
      if (contact_in_set(k)) best = std::min(best, (coords.row(i) - coords.row(k)).norm());
    return best;
  };
  for (Eigen::Index c : spread_contacts(coords, std::min<Eigen::Index>(kActiveSetStart, n))) add_contact(c);
  double least_upper = std::numeric_limits<double>::infinity();  // over the subsets so far
  while (true) {
    std::vector<Eigen::Index> rows;
    for (Eigen::Index i = 0; i < n * per; ++i)
      if (in_set[static_cast<std::size_t>(i)]) rows.push_back(i);
    Matrix sub(static_cast<Eigen::Index>(rows.size()), 6);
    for (std::size_t k = 0; k < rows.size(); ++k) sub.row(static_cast<Eigen::Index>(k)) = w.row(rows[k]);
    HullQuality h = hull_quality(sub, tol, boundary_tol, volume, joggle);
    if (static_cast<Eigen::Index>(rows.size()) == n * per) return {h.epsilon, h.volume, h.reason, true, least_upper};
    if (until_closed && h.reason.empty()) return {h.epsilon, h.volume, h.reason, false, least_upper, least_upper < below};
    if (h.planes.rows() == 0) {  // the subset does not span 6-D: widen it by its farthest contacts
      std::vector<double> far(n);
      for (Eigen::Index i = 0; i < n; ++i) far[i] = contact_in_set(i) ? -1.0 : distance_to_set(i);
      std::vector<Eigen::Index> order(n);
      std::iota(order.begin(), order.end(), Eigen::Index{0});
      std::stable_sort(order.begin(), order.end(), [&](Eigen::Index a, Eigen::Index b) { return far[a] > far[b]; });
      for (Eigen::Index k = 0; k < std::min<Eigen::Index>(kActiveSetStart, n); ++k) add_contact(order[k]);
      continue;
    }
    const Eigen::VectorXd d = -h.planes.col(6);
    std::vector<Eigen::Index> order(d.size());
    std::iota(order.begin(), order.end(), Eigen::Index{0});
    std::stable_sort(order.begin(), order.end(), [&](Eigen::Index a, Eigen::Index b) { return d[a] < d[b]; });
    const double lower = d[order[0]];
    double upper = std::numeric_limits<double>::infinity();
    std::vector<Eigen::Index> add;
    for (Eigen::Index f : order) {
      // A facet at or beyond the bound cannot be one the whole hull reaches past by more than the
      // tolerance (its own reach is at least its distance), so the remaining facets change nothing.
      if (d[f] >= upper - boundary_tol) break;
      Eigen::Index best = 0;
      const double reach = (w * h.planes.row(f).head<6>().transpose()).maxCoeff(&best);
      upper = std::min(upper, reach);
      if (d[f] < upper - boundary_tol) add.push_back(best);
    }
    if (upper <= boundary_tol)  // a direction no wrench reaches beyond the origin
      return {0.0, h.volume, h.reason.empty() ? origin_reason(upper, boundary_tol) : h.reason, false, upper};
    if (upper <= lower + boundary_tol) return {h.epsilon, h.volume, h.reason, false, upper};  // the bounds meet
    least_upper = std::min(least_upper, upper);
    if (least_upper < below) {  // epsilon is not wanted: only force closure may be left to decide
      if (closed || h.reason.empty()) return {h.reason.empty() ? h.epsilon : 0.0, h.volume, "", false, least_upper, true};
      until_closed = true;
    }
    bool grew = false;
    for (Eigen::Index r : add)
      if (!in_set[static_cast<std::size_t>(r)]) in_set[static_cast<std::size_t>(r)] = 1, grew = true;
    if (!grew) std::fill(in_set.begin(), in_set.end(), 1);  // cannot happen in exact arithmetic
  }
}

void check_options(const QualityOptions& o) {
  if (o.max_hull_wrenches < 7)
    throw std::invalid_argument("max_hull_wrenches: expected an integer >= 7, got " +
                                std::to_string(o.max_hull_wrenches));
  if (!(o.min_epsilon >= 0.0) || !std::isfinite(o.min_epsilon))
    throw std::invalid_argument("min_epsilon: expected a finite value >= 0, got " + std::to_string(o.min_epsilon));
}

}  // namespace

namespace {

/// The largest t with t u in conv(w), for a wrench set whose hull holds the origin strictly and a
/// unit u (see force_resistance()).
double ray_exit(const Matrix& w, const Eigen::VectorXd& u, double boundary_tol) {
  double t = (w * u).maxCoeff();
  if (!(t > 0.0)) return 0.0;
  for (int step = 0; step < 100; ++step) {
    const Matrix shifted = w.rowwise() - t * u.transpose();
    const MinNormPoint m = min_norm_point(shifted);
    const double xn = m.x.norm();
    if (!m.ok || xn <= boundary_tol) return t;  // t u lies in the hull (within rounding)
    const Eigen::VectorXd a = -m.x / xn;        // outward normal of a plane supporting the hull
    const double along = a.dot(u);
    if (!(along > 0.0)) return t;
    const double next = (w * a).maxCoeff() / along;
    if (!(next < t - boundary_tol)) return std::min(t, next);
    t = next;
  }
  return t;
}

}  // namespace

Eigen::VectorXd force_resistance(const Points& points, const Points& normals, const Eigen::Vector3d& center,
                                 double radius, const Points& directions, const ContactModel& contact) {
  for (Eigen::Index k = 0; k < directions.rows(); ++k) {
    const double n = directions.row(k).norm();
    if (!directions.row(k).allFinite() || std::abs(n - 1.0) > 1e-6)
      throw std::invalid_argument("directions: row " + std::to_string(k) + " is not a finite unit vector (norm " +
                                  std::to_string(n) + ")");
  }
  QualityOptions qo;
  qo.contact = contact;
  qo.volume = false;
  qo.open_volume = false;
  qo.min_epsilon = std::numeric_limits<double>::max();  // force closure decided, the hull skipped
  const GraspQuality q = grasp_quality(points, normals, center, radius, qo);  // validates
  Eigen::VectorXd out = Eigen::VectorXd::Zero(directions.rows());
  if (!q.force_closure) return out;
  const Matrix w = unique_rows(wrench_matrix(points, normals, center, radius, contact));
  const double boundary_tol = kRtol * w.rowwise().norm().maxCoeff();
  for (Eigen::Index k = 0; k < directions.rows(); ++k) {
    Eigen::VectorXd u = Eigen::VectorXd::Zero(6);
    u.head<3>() = directions.row(k).transpose().normalized();
    out[k] = std::max(ray_exit(w, u, boundary_tol), q.epsilon);  // q.epsilon: a lower bound of epsilon
  }
  return out;
}

Points load_directions() {
  Points d(6, 3);
  d << Eigen::Matrix3d::Identity(), -Eigen::Matrix3d::Identity();
  return d;
}

double load_resistance(const Points& points, const Points& normals, const Eigen::Vector3d& center, double radius,
                       const ContactModel& contact) {
  return force_resistance(points, normals, center, radius, load_directions(), contact).minCoeff();
}

double epsilon_upper_bound(const Wrenches& wrenches) {
  if (!wrenches.allFinite()) throw std::invalid_argument("wrenches: non-finite value");
  if (wrenches.rows() == 0) return 0.0;
  const Matrix w = wrenches;
  Eigen::JacobiSVD<Matrix> svd(w, Eigen::ComputeFullV);
  return support_bound(w, svd.matrixV());
}

GraspQuality grasp_quality(const Points& points, const Points& normals, const Eigen::Vector3d& center,
                           double radius, const QualityOptions& options) {
  check_options(options);
  const Wrenches all = wrench_matrix(points, normals, center, radius, options.contact);  // validates
  GraspQuality q;
  q.n_contacts = static_cast<int>(points.rows());
  q.n_wrenches = static_cast<int>(all.rows());
  if (q.n_contacts == 0) {
    q.reason = "no contacts";
    return q;
  }
  const Eigen::Index per = options.contact.wrenches_per_contact();

  // Reduction 1: the vertices of each normal group's point hull.
  Points n_in(normals.rows(), 3);
  for (Eigen::Index i = 0; i < normals.rows(); ++i) n_in.row(i) = -normals.row(i) / normals.row(i).norm();
  const std::vector<Eigen::Index> keep = group_hull_vertices(points, n_in);
  const auto kept = static_cast<Eigen::Index>(keep.size());
  Matrix w(kept * per, 6);
  Matrix coords(kept, 6);
  for (Eigen::Index k = 0; k < kept; ++k) {
    w.middleRows(k * per, per) = all.middleRows(keep[k] * per, per);
    coords.row(k) << points.row(keep[k]) / radius, n_in.row(keep[k]);
  }

  const Matrix distinct = unique_rows(w);
  Eigen::JacobiSVD<Matrix> svd(distinct, Eigen::ComputeFullV);
  const Eigen::VectorXd& s = svd.singularValues();
  const double tol = kRtol * s(0);
  q.rank = count_above(s, tol);
  if (q.rank < 6) {
    q.reason = "rank-deficient wrench set (rank " + std::to_string(q.rank) +
               " < 6): the contacts cannot resist every wrench";
    return q;
  }
  q.epsilon_bound = support_bound(distinct, svd.matrixV());
  const double boundary_tol = kRtol * w.rowwise().norm().maxCoeff();
  // Where the origin lies, by Wolfe's algorithm: not force-closure, or force-closure with a lower
  // bound of epsilon, or unknown (the hull decides).
  OriginInHull origin;
  if (!options.open_volume || options.min_epsilon > 0.0) origin = locate_origin(distinct, boundary_tol);
  if (!options.open_volume && origin.separated) {
    q.reason = "the origin is outside the wrench hull";
    q.volume_exact = false;
    return q;
  }
  // Below min_epsilon the hull is not wanted. The hull-free bound decides first, then a descent of
  // the support function from it; where neither does, the active set's hulls, whose facets bound
  // epsilon from above as the set grows, stop once they bound it below min_epsilon.
  double bound = q.epsilon_bound, lower = origin.inner;
  if (options.min_epsilon > 0.0 && bound >= options.min_epsilon) {
    Matrix dirs(6, 12);
    dirs << Matrix::Identity(6, 6), svd.matrixV();
    bound = std::min(bound, descent_bound(distinct, dirs));
  }
  const bool skip = options.min_epsilon > 0.0 && bound < options.min_epsilon;
  if (skip && origin.separated) {  // not force-closure: epsilon 0 is exact
    q.reason = "the origin is outside the wrench hull";
    q.volume_exact = false;
    q.epsilon_bound = bound;
    return q;
  }
  if (skip && lower > 0.0) {  // force closure proven by Wolfe's simplex, epsilon bounded below it
    q.volume_exact = false;
    q.epsilon_bound = bound;
    q.epsilon_computed = false;
    q.epsilon = lower;
    q.force_closure = true;
    return q;
  }
  if (!skip && w.rows() <= options.max_hull_wrenches) {
    HullQuality h = hull_quality(w, tol, boundary_tol, options.volume, options.joggle);
    q.epsilon = h.epsilon;
    q.volume = h.volume;
    q.reason = std::move(h.reason);
  } else {
    // The active set (reduction 2). Skipped, it only decides force closure: hulls of growing
    // subsets of the contacts, stopping at the first that holds the origin, or at the whole set.
    ActiveSetQuality a = active_set_quality(w, per, coords, tol, options.volume && !skip, boundary_tol, options.joggle,
                                            skip, options.min_epsilon, lower > 0.0);
    q.epsilon = a.epsilon;
    q.volume = a.volume;
    q.reason = std::move(a.reason);
    q.volume_exact = a.exact;
    if (skip || a.below) {  // epsilon below min_epsilon: no volume, and a lower bound of epsilon
      q.volume_exact = false;
      q.epsilon_bound = std::min(bound, a.upper);
      if (q.reason.empty() && !a.exact) {
        q.epsilon = std::max(q.epsilon, lower);
        q.epsilon_computed = false;
      }
    }
  }
  if (!q.reason.empty()) q.epsilon = 0.0;
  q.force_closure = q.reason.empty();
  if (!options.volume) q.volume_exact = false;
  return q;
}

}  // namespace pairgrasp
