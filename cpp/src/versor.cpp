// The six-pairing versor solver (see versor.hpp for the method and its degenerate cases).
#include <pairgrasp/error.hpp>
#include <pairgrasp/versor.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <utility>

namespace pairgrasp {

namespace {

using Eigen::Quaterniond;
using Eigen::Vector3d;

constexpr double kPi = 3.14159265358979323846;
constexpr double kTiny = 1e-14;   // below this a cross product or a difference is zero
constexpr double kParallel = 1e-9;  // sine below which two differences count as parallel
constexpr double kTriadBelow = 1e-3;  // meetings worse conditioned than this get TRIAD company
constexpr int kMaxHyp = 16;

struct Pairing {
  Vector3d a, b;
  bool valid = false;
};

struct Hyp {
  Quaterniond q;
  int s = 0;          // satisfied pairings
  double rms = 0.0;   // rms angle over satisfied pairings
};

Quaterniond from_axis_angle(const Vector3d& m, double theta) {
  const double h = 0.5 * theta;
  const double s = std::sin(h);
  Quaterniond q(std::cos(h), s * m.x(), s * m.y(), s * m.z());
  q.normalize();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  return q;
}

// Least-squares angle about the unit axis m over the pairings in `mask`: maximises
// sum_k B_k . R(theta) A_k, i.e. theta = atan2(sum m.(A x B), sum A.B - (m.A)(m.B)) (eq. 18 made
// signed). Returns false when every pairing lies along m (no angle information).
bool axis_angle(const std::array<Pairing, 3>& p, unsigned mask, const Vector3d& m, double& theta) {
  double num = 0.0, den = 0.0, weight = 0.0;
  for (int k = 0; k < 3; ++k) {
    if (!(mask & (1u << k)) || !p[k].valid) continue;
    const Vector3d& a = p[k].a;
    const Vector3d& b = p[k].b;
    const double ma = m.dot(a), mb = m.dot(b);
    num += m.dot(a.cross(b));
    den += a.dot(b) - ma * mb;
    weight += std::sqrt(std::max(0.0, (1.0 - ma * ma) * (1.0 - mb * mb)));
  }
  if (weight < 1e-12 || num * num + den * den < 1e-28) return false;
  theta = std::atan2(num, den);
  return true;
}

// Satisfied: |R.A - B| <= chord (the chord of the angle tolerance on the unit sphere); the
// residual angle is 2 asin(|R.A - B| / 2).
void score(const std::array<Pairing, 3>& p, double chord, Hyp& h) {
  h.s = 0;
  double sum = 0.0;
  for (int k = 0; k < 3; ++k) {
    if (!p[k].valid) continue;
    const double c2 = (h.q * p[k].a - p[k].b).squaredNorm();
    if (c2 <= chord * chord) {
      ++h.s;
      const double ang = 2.0 * std::asin(std::min(1.0, 0.5 * std::sqrt(c2)));
      sum += ang * ang;
    }
  }
  h.rms = h.s ? std::sqrt(sum / h.s) : 0.0;
}

unsigned satisfied_mask(const std::array<Pairing, 3>& p, double chord, const Quaterniond& q) {
  unsigned mask = 0;
  for (int k = 0; k < 3; ++k)
    if (p[k].valid && (q * p[k].a - p[k].b).squaredNorm() <= chord * chord) mask |= 1u << k;
  return mask;
}

// Orthonormal frame with first axis x and second axis in the plane of x and y. Needs x, y not
// parallel (checked by the caller).
Eigen::Matrix3d triad(const Vector3d& x, const Vector3d& y) {
  Eigen::Matrix3d f;
  const Vector3d e1 = x.normalized();
  const Vector3d e3 = x.cross(y).normalized();
  f.col(0) = e1;
  f.col(1) = e3.cross(e1);
  f.col(2) = e3;
  return f;
}

struct HypSet {
  std::array<Hyp, kMaxHyp> h;
  int n = 0;
  void add(const Quaterniond& q) {
    if (n < kMaxHyp) h[n++].q = q;
  }
};

// All rotation hypotheses of one point order, scored and polished.
void order_hypotheses(const std::array<Pairing, 3>& p, const PairPoseOptions& opt, double sin_collinear,
                      int min_s, HypSet& set) {
  const double chord = 2.0 * std::sin(0.5 * std::min(opt.angle_tolerance, kPi));
  std::array<Vector3d, 3> d;
  std::array<double, 3> dn{};
  bool all_small = true;
  for (int k = 0; k < 3; ++k) {
    if (!p[k].valid) continue;
    d[k] = p[k].a - p[k].b;
    dn[k] = d[k].norm();
    if (dn[k] > chord) all_small = false;
  }
  // All differences ~ 0: the identity.
  if (all_small) set.add(Quaterniond::Identity());
  // Meetings of two great circles (eq. 17), angle from both pairings. best_sin: the sine between
  // the two differences of the best-conditioned meeting.
  double best_sin = 0.0;
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j) {
      if (!p[i].valid || !p[j].valid || dn[i] <= kTiny || dn[j] <= kTiny) continue;
      const Vector3d c = d[i].cross(d[j]);
      const double cn = c.norm();
      if (cn <= kParallel * dn[i] * dn[j] || cn <= kTiny) continue;  // parallel: other meetings
      const Vector3d m = c / cn;
      double theta;
      if (axis_angle(p, (1u << i) | (1u << j), m, theta)) {
        set.add(from_axis_angle(m, theta));
        best_sin = std::max(best_sin, cn / (dn[i] * dn[j]));
      }
    }
  // A_k = B_k: the axis is +-A_k (the bisector when they differ within tolerance), the angle
  // comes from another pairing.
  for (int k = 0; k < 3; ++k) {
    if (!p[k].valid || dn[k] > chord) continue;
    const Vector3d m = (p[k].a + p[k].b).normalized();
    for (int j = 0; j < 3; ++j) {
      if (j == k || !p[j].valid) continue;
      double theta;
      if (axis_angle(p, 1u << j, m, theta)) set.add(from_axis_angle(m, theta));
    }
  }
  for (int k = 0; k < set.n; ++k) score(p, chord, set.h[k]);
  // TRIAD fallback when no meeting is well conditioned (every difference parallel: the axis lies
  // in the plane of coplanar vectors; only the approximate identity / axis = A_k hypotheses are
  // left).
  if (best_sin < kTriadBelow) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        if (i == j || !p[i].valid || !p[j].valid) continue;
        if (p[i].a.cross(p[j].a).norm() <= sin_collinear || p[i].b.cross(p[j].b).norm() <= sin_collinear)
          continue;
        const Eigen::Matrix3d r = triad(p[i].b, p[j].b) * triad(p[i].a, p[j].a).transpose();
        Quaterniond q(r);
        q.normalize();
        if (q.w() < 0) q.coeffs() = -q.coeffs();
        const int before = set.n;
        set.add(q);
        if (set.n > before) score(p, chord, set.h[set.n - 1]);
      }
  }
  // Polish: least-squares angle about the hypothesis axis over the satisfied pairings.
  for (int k = 0; k < set.n; ++k) {
    Hyp& h = set.h[k];
    if (h.s < min_s) continue;
    const Vector3d v = h.q.vec();
    const double vn = v.norm();
    if (vn <= kTiny) continue;
    double theta;
    if (!axis_angle(p, satisfied_mask(p, chord, h.q), v / vn, theta)) continue;
    Hyp polished;
    polished.q = from_axis_angle(v / vn, theta);
    score(p, chord, polished);
    if (polished.s >= h.s && polished.rms <= h.rms) h = polished;
  }
}

void check_finite(const char* name, const Vector3d& v) {
  if (!v.allFinite()) throw std::invalid_argument(std::string(name) + ": expected finite values");
}

void check_unit(const char* name, const Vector3d& v) {
  check_finite(name, v);
  const double n = v.norm();
  if (std::abs(n - 1.0) > 1e-6)
    throw std::invalid_argument(std::string(name) + ": expected a unit vector, got norm " + std::to_string(n));
}

double max_cross(const Vector3d& x, const Vector3d& y, const Vector3d* u) {
  double s = x.cross(y).norm();
  if (u) s = std::max({s, x.cross(*u).norm(), y.cross(*u).norm()});
  return s;
}

struct Ranked {
  Hyp h;
  int order;
};

// Sort key: more agreement, then smaller residual (residuals within 1e-9 rad tie), then order.
bool better(const Ranked& x, const Ranked& y) {
  const int ax = x.h.s * (x.h.s - 1) / 2, ay = y.h.s * (y.h.s - 1) / 2;
  if (ax != ay) return ax > ay;
  const double rx = x.h.rms <= 1e-9 ? 0.0 : x.h.rms, ry = y.h.rms <= 1e-9 ? 0.0 : y.h.rms;
  if (rx != ry) return rx < ry;
  if (x.order != y.order) return x.order < y.order;
  return x.h.rms < y.h.rms;
}

}  // namespace

const char* to_string(PairPoseStatus status) {
  switch (status) {
    case PairPoseStatus::Ok: return "ok";
    case PairPoseStatus::Underdetermined: return "underdetermined";
    case PairPoseStatus::NoAgreement: return "no_agreement";
  }
  return "unknown";
}

Pose PairPoseCandidate::pose() const {
  Pose p = Pose::Identity();
  p.linear() = rotation;
  p.translation() = translation;
  return p;
}

Eigen::Matrix3d versor_rotation(double angle, const Eigen::Vector3d& axis) {
  return from_axis_angle(axis.normalized(), angle).toRotationMatrix();
}

void canonicalize_versor(double& angle, Eigen::Vector3d& axis) {
  angle = std::remainder(angle, 2.0 * kPi);  // (-pi, pi] up to the tie at -pi
  if (angle == 0.0) {
    axis = Vector3d::UnitZ();
    return;
  }
  const bool upper = axis.z() > 0 || (axis.z() == 0 && (axis.y() > 0 || (axis.y() == 0 && axis.x() > 0)));
  if (!upper) {
    axis = -axis;
    angle = -angle;
  }
  if (angle <= -kPi) angle = kPi;  // (pi, m) == (-pi, m)
}

double rotation_distance(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  const Quaterniond d = a.conjugate() * b;
  return 2.0 * std::atan2(d.vec().norm(), std::abs(d.w()));
}

void solve_pair_pose(const Vector3d& gp0, const Vector3d& gp1, const Vector3d& gn0, const Vector3d& gn1,
                     const Vector3d& tp0, const Vector3d& tp1, const Vector3d& tn0, const Vector3d& tn1,
                     const PairPoseOptions& options, PairPoseResult& result) {
  check_finite("gp0", gp0);
  check_finite("gp1", gp1);
  check_unit("gn0", gn0);
  check_unit("gn1", gn1);
  check_finite("tp0", tp0);
  check_finite("tp1", tp1);
  check_unit("tn0", tn0);
  check_unit("tn1", tn1);
  if (!(options.angle_tolerance > 0) || !std::isfinite(options.angle_tolerance))
    throw std::invalid_argument("angle_tolerance: expected a positive finite angle (radians), got " +
                                std::to_string(options.angle_tolerance));
  if (options.min_agreement < 1 || options.min_agreement > 3)
    throw std::invalid_argument("min_agreement: expected 1..3, got " + std::to_string(options.min_agreement));
  if (!(options.collinear_tolerance >= 0) || !std::isfinite(options.collinear_tolerance))
    throw std::invalid_argument("collinear_tolerance: expected a non-negative finite angle (radians), got " +
                                std::to_string(options.collinear_tolerance));
  result.candidates.clear();

  // Gripper normals are flipped: at a contact the target normal opposes the finger's.
  const Vector3d a0 = -gn0, a1 = -gn1;
  const Vector3d dg = gp1 - gp0, dt = tp1 - tp0;
  const double lg = dg.norm(), lt = dt.norm();
  const double scale = 1.0 + std::max({gp0.cwiseAbs().maxCoeff(), gp1.cwiseAbs().maxCoeff(),
                                       tp0.cwiseAbs().maxCoeff(), tp1.cwiseAbs().maxCoeff()});
  const bool has_u = lg > 1e-9 * scale && lt > 1e-9 * scale;
  const Vector3d ug = has_u ? Vector3d(dg / lg) : Vector3d::Zero();
  const Vector3d ut = has_u ? Vector3d(dt / lt) : Vector3d::Zero();

  // Collinear side (antipodal pair, or coincident points with parallel normals): roll is free.
  const double sin_collinear = std::sin(std::min(options.collinear_tolerance, 0.5 * kPi));
  if (max_cross(a0, a1, has_u ? &ug : nullptr) <= sin_collinear ||
      max_cross(tn0, tn1, has_u ? &ut : nullptr) <= sin_collinear) {
    result.status = PairPoseStatus::Underdetermined;
    return;
  }

  // Agreement s(s-1)/2 >= min_agreement  <=>  s >= min_s.
  const int min_s = options.min_agreement <= 1 ? 2 : 3;
  std::array<Ranked, 2 * kMaxHyp> ranked;
  int nr = 0;
  for (int order = 0; order < 2; ++order) {
    std::array<Pairing, 3> p;
    p[0] = {a0, order == 0 ? tn0 : tn1, true};
    p[1] = {a1, order == 0 ? tn1 : tn0, true};
    p[2] = {ug, order == 0 ? ut : Vector3d(-ut), has_u};
    HypSet set;
    order_hypotheses(p, options, sin_collinear, min_s, set);
    // Best first within the order, then drop hypotheses that repeat a kept rotation.
    std::array<Ranked, kMaxHyp> local;
    int nl = 0;
    for (int k = 0; k < set.n; ++k)
      if (set.h[k].s >= min_s) local[nl++] = {set.h[k], order};
    std::sort(local.begin(), local.begin() + nl, better);
    const int first = nr;
    for (int k = 0; k < nl; ++k) {
      bool repeat = false;
      for (int r = first; r < nr && !repeat; ++r)
        repeat = rotation_distance(ranked[r].h.q, local[k].h.q) <= options.angle_tolerance;
      if (!repeat) ranked[nr++] = local[k];
    }
  }
  if (nr == 0) {
    result.status = PairPoseStatus::NoAgreement;
    return;
  }
  std::sort(ranked.begin(), ranked.begin() + nr, better);

  const Vector3d pg = 0.5 * (gp0 + gp1), pt = 0.5 * (tp0 + tp1);
  result.status = PairPoseStatus::Ok;
  result.candidates.resize(nr);
  for (int r = 0; r < nr; ++r) {
    PairPoseCandidate& c = result.candidates[r];
    const Quaterniond& q = ranked[r].h.q;
    c.versor = q;
    c.rotation = q.toRotationMatrix();
    c.translation = pt - c.rotation * pg;  // eq. 19
    const double vn = q.vec().norm();
    c.angle = 2.0 * std::atan2(vn, q.w());
    c.axis = vn > 0 ? Vector3d(q.vec() / vn) : Vector3d::UnitZ();
    canonicalize_versor(c.angle, c.axis);
    c.agreement = ranked[r].h.s * (ranked[r].h.s - 1) / 2;
    c.order = ranked[r].order;
    c.residual = ranked[r].h.rms;
  }
}

PairPoseResult solve_pair_pose(const Vector3d& gp0, const Vector3d& gp1, const Vector3d& gn0,
                               const Vector3d& gn1, const Vector3d& tp0, const Vector3d& tp1,
                               const Vector3d& tn0, const Vector3d& tn1, const PairPoseOptions& options) {
  PairPoseResult r;
  solve_pair_pose(gp0, gp1, gn0, gn1, tp0, tp1, tn0, tn1, options, r);
  return r;
}

PairPoseResult solve_pair_pose(const Points& gripper_points, const Points& gripper_normals,
                               const Points& target_points, const Points& target_normals,
                               const PairPoseOptions& options) {
  const std::pair<const char*, const Points*> args[] = {{"gripper_points", &gripper_points},
                                                        {"gripper_normals", &gripper_normals},
                                                        {"target_points", &target_points},
                                                        {"target_normals", &target_normals}};
  for (const auto& [name, m] : args) {
    if (m->rows() != 2)
      throw std::invalid_argument(std::string(name) + ": expected (2,3), got (" + std::to_string(m->rows()) + ",3)");
    if (!m->allFinite()) throw std::invalid_argument(std::string(name) + ": expected finite values");
  }
  for (const auto& [name, m] : {args[1], args[3]})
    for (int r = 0; r < 2; ++r) {
      const double n = m->row(r).norm();
      if (std::abs(n - 1.0) > 1e-6)
        throw std::invalid_argument(std::string(name) + ": row " + std::to_string(r) +
                                    " expected a unit vector, got norm " + std::to_string(n));
    }
  return solve_pair_pose(gripper_points.row(0).transpose(), gripper_points.row(1).transpose(),
                         gripper_normals.row(0).transpose(), gripper_normals.row(1).transpose(),
                         target_points.row(0).transpose(), target_points.row(1).transpose(),
                         target_normals.row(0).transpose(), target_normals.row(1).transpose(), options);
}

}  // namespace pairgrasp
