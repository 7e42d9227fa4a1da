// The six-pairing versor solver (see versor.hpp for the method and its degenerate cases).
#include <pairgrasp/error.hpp>
#include <pairgrasp/versor.hpp>

#include "versor_core.hpp"

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

// No default member values: the solver's arrays of them (64 per call) are written before they
// are read (add() and score() set every field), and zeroing them cost more than a rejected
// correspondence's own arithmetic.
struct Hyp {
  Quaterniond q;  // w >= 0
  int s;          // satisfied pairings
  unsigned mask;  // which
  double rms;     // rms angle over satisfied pairings
};

Quaterniond from_axis_angle(const Vector3d& m, double theta) {
  const double h = 0.5 * theta;
  const double s = std::sin(h);
  Quaterniond q(std::cos(h), s * m.x(), s * m.y(), s * m.z());
  q.normalize();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  return q;
}

// The terms of a rotation about the unit axis m, per valid pairing k: m.A_k, m.B_k and
// z_k = (A_k.B_k - (m.A_k)(m.B_k), m.(A_k x B_k)) (order_hypotheses computes them). Both the
// rotation about m (rotation_about) and the closed-form test of its residuals are sums of them
// over a mask.
struct AxisTerms {
  std::array<double, 3> ma{}, mb{}, re{}, im{};
};

// Least-squares rotation about the unit axis m over the pairings in `mask`: the angle maximising
// sum_k B_k . R(theta) A_k is theta = atan2(num, den), num = sum m.(A x B) (the im terms),
// den = sum A.B - (m.A)(m.B) (the re terms; eq. 18 made signed). The versor is built from
// (num, den) without trigonometry: with r = |(num, den)|, (cos theta/2, sin theta/2 m) is
// proportional to (r + den, num m) and to (num, (r - den) m); the first is used for den >= 0, the
// second (exact at a half turn) otherwise. Returns false when every pairing lies along m (no angle
// information).
bool rotation_about(const std::array<Pairing, 3>& p, const AxisTerms& t, unsigned mask, const Vector3d& m,
                    Quaterniond& q) {
  double num = 0.0, den = 0.0, weight = 0.0;
  for (int k = 0; k < 3; ++k) {
    if (!(mask & (1u << k)) || !p[k].valid) continue;
    num += t.im[k];
    den += t.re[k];
    weight += std::max(0.0, (1.0 - t.ma[k] * t.ma[k]) * (1.0 - t.mb[k] * t.mb[k]));
  }
  const double r2 = num * num + den * den;
  if (weight < 1e-24 || r2 < 1e-28) return false;
  // (1 + cos, sin) ~ (sin, 1 - cos): use the form without cancellation.
  const double r = std::sqrt(r2);
  if (den >= 0)
    q = Quaterniond(r + den, num * m.x(), num * m.y(), num * m.z());
  else
    q = Quaterniond(num, (r - den) * m.x(), (r - den) * m.y(), (r - den) * m.z());
  q.normalize();
  return true;
}

// Satisfied: |R.A - B| <= chord (the chord of the angle tolerance on the unit sphere); the
// residual angle is 2 asin(|R.A - B| / 2). `all`: only a rotation satisfying every valid pairing
// matters, so the first failing one ends the scoring (s = 0).
void score(const std::array<Pairing, 3>& p, double chord, Hyp& h, bool all = false) {
  h.s = 0;
  h.mask = 0;
  h.rms = 0.0;
  double sum = 0.0;
  const Eigen::Matrix3d r = h.q.toRotationMatrix();
  for (int k = 0; k < 3; ++k) {
    if (!p[k].valid) continue;
    const double c2 = (r * p[k].a - p[k].b).squaredNorm();
    if (all && c2 > chord * chord) {
      h.s = 0;
      h.mask = 0;
      return;
    }
    if (c2 <= chord * chord) {
      ++h.s;
      h.mask |= 1u << k;
      const double ang = 2.0 * std::asin(std::min(1.0, 0.5 * std::sqrt(c2)));
      sum += ang * ang;
    }
  }
  h.rms = h.s ? std::sqrt(sum / h.s) : 0.0;
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
  // Adds and scores q; returns the hypothesis or nullptr when full.
  const Hyp* add(const Quaterniond& q, const std::array<Pairing, 3>& p, double chord, bool all) {
    if (n >= kMaxHyp) return nullptr;
    Hyp& x = h[n++];
    x.q = q;
    if (x.q.w() < 0) x.q.coeffs() = -x.q.coeffs();
    score(p, chord, x, all);
    return &x;
  }
};

// Sort key within one order: more satisfied pairings, then smaller residual.
bool hyp_better(const Hyp& x, const Hyp& y) {
  if (x.s != y.s) return x.s > y.s;
  return x.rms < y.rms;
}

// The distinct rotations of one point order that satisfy at least min_s pairings, best first,
// polished. Returns their number (written to `out`).
int order_hypotheses(const std::array<Pairing, 3>& p, double chord, double sin_collinear, int min_s,
                     double cos_half_tol, std::array<Hyp, kMaxHyp>& out) {
  // Early rejection (exact, no rotation is missed): a rotation that satisfies pairings i and j
  // within chord c keeps |A_i.A_j - B_i.B_j| <= 2c, since R preserves dot products. When every
  // pairing must be satisfied, one failing pair rules the order out.
  if (min_s >= 3) {
    for (int i = 0; i < 3; ++i)
      for (int j = i + 1; j < 3; ++j)
        if (p[i].valid && p[j].valid && std::abs(p[i].a.dot(p[j].a) - p[i].b.dot(p[j].b)) > 2.0 * chord) return 0;
  }
  int nvalid = 0;
  for (int k = 0; k < 3; ++k) nvalid += p[k].valid;
  if (nvalid < min_s) return 0;  // a hypothesis satisfies at most the valid pairings
  const bool need_all = min_s >= nvalid;  // only rotations satisfying every valid pairing count
  HypSet set;
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
  if (all_small) set.add(Quaterniond::Identity(), p, chord, need_all);
  // Meetings of two great circles (eq. 17), best conditioned first; the angle comes from both
  // pairings. Once a meeting's rotation satisfies every pairing, the other meetings can only
  // give that rotation again, so they are not computed.
  struct Meeting {
    Vector3d c;
    double cn, sine;
    int i, j;
  };
  std::array<Meeting, 3> meet;
  int nm = 0;
  double best_sin = 0.0;
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j) {
      if (!p[i].valid || !p[j].valid || dn[i] <= kTiny || dn[j] <= kTiny) continue;
      Meeting mt;
      mt.c = d[i].cross(d[j]);
      mt.cn = mt.c.norm();
      mt.sine = mt.cn / (dn[i] * dn[j]);
      if (mt.sine <= kParallel || mt.cn <= kTiny) continue;  // parallel: the other meetings
      mt.i = i;
      mt.j = j;
      meet[nm++] = mt;
      best_sin = std::max(best_sin, mt.sine);
    }
  for (int a = 1; a < nm; ++a)  // at most three: insertion sort, best conditioned first
    for (int b = a; b > 0 && meet[b].sine > meet[b - 1].sine; --b) std::swap(meet[b], meet[b - 1]);
  // A rotation about the unit axis m keeps every vector's component along m, so its residual
  // R.A_t - B_t has the component m.(A_t - B_t) whatever the angle: a chord beyond it rules the
  // axis out for pairing t. When every valid pairing must be satisfied (min_s >= nvalid), a
  // hypothesis with such an axis never reaches the output, and is not computed. (The margin keeps
  // the rounding of the rotation's own residual on the side of computing it.)
  auto axis_fails = [&](const Vector3d& m, double mn) {
    for (int t = 0; t < 3; ++t)
      if (p[t].valid && std::abs(m.dot(d[t])) > (chord * (1.0 + 1e-9) + 1e-12) * mn) return true;
    return false;
  };
  auto axis_terms = [&](const Vector3d& m) {
    AxisTerms t;
    for (int k = 0; k < 3; ++k) {
      if (!p[k].valid) continue;
      t.ma[k] = m.dot(p[k].a);
      t.mb[k] = m.dot(p[k].b);
      t.re[k] = p[k].a.dot(p[k].b) - t.ma[k] * t.mb[k];
      t.im[k] = m.dot(p[k].a.cross(p[k].b));
    }
    return t;
  };
  // rotation_about(p, t, mask, m) in closed form: with Z the sum of the z_k over the mask, its
  // angle is arg Z, and pairing k's squared residual |R.A_k - B_k|^2 is
  // |A_k|^2 + |B_k|^2 - 2 (m.A_k)(m.B_k) - 2 Re(z_k conj Z) / |Z|. A residual beyond the chord
  // (with the margin above) rules the rotation out when every pairing must be satisfied.
  auto rotation_fails = [&](const AxisTerms& t, unsigned mask) {
    double zr = 0.0, zi = 0.0;
    for (int k = 0; k < 3; ++k)
      if (mask & (1u << k)) zr += t.re[k], zi += t.im[k];
    const double zn = std::sqrt(zr * zr + zi * zi);
    if (!(zn > 1e-14)) return false;  // rotation_about decides
    const double limit = chord * chord * (1.0 + 1e-9) + 1e-12;
    for (int k = 0; k < 3; ++k) {
      if (!p[k].valid) continue;
      const double r2 = p[k].a.squaredNorm() + p[k].b.squaredNorm() - 2.0 * t.ma[k] * t.mb[k] -
                        2.0 * (t.re[k] * zr + t.im[k] * zi) / zn;
      if (r2 > limit) return true;
    }
    return false;
  };
  for (int k = 0; k < nm; ++k) {
    const Vector3d m = meet[k].c / meet[k].cn;
    const unsigned mask = (1u << meet[k].i) | (1u << meet[k].j);
    if (need_all && axis_fails(meet[k].c, meet[k].cn)) continue;
    const AxisTerms terms = axis_terms(m);  // for the test and the rotation alike
    if (need_all && rotation_fails(terms, mask)) continue;
    Quaterniond q;
    if (!rotation_about(p, terms, mask, m, q)) continue;
    const Hyp* h = set.add(q, p, chord, need_all);
    if (h && h->s == nvalid) break;
  }
  // A_k = B_k: the axis is +-A_k (the bisector when they differ within tolerance), the angle
  // comes from another pairing.
  for (int k = 0; k < 3; ++k) {
    if (!p[k].valid || dn[k] > chord) continue;
    const Vector3d m = (p[k].a + p[k].b).normalized();
    if (need_all && axis_fails(m, 1.0)) continue;
    const AxisTerms terms = axis_terms(m);  // the same axis for every j
    for (int j = 0; j < 3; ++j) {
      if (j == k || !p[j].valid || (need_all && rotation_fails(terms, 1u << j))) continue;
      Quaterniond q;
      if (rotation_about(p, terms, 1u << j, m, q)) set.add(q, p, chord, need_all);
    }
  }
  // TRIAD fallback when no meeting is well conditioned (every difference parallel: the axis lies
  // in the plane of coplanar vectors; only the approximate identity / axis = A_k hypotheses are
  // left).
  if (best_sin < kTriadBelow) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        if (i == j || !p[i].valid || !p[j].valid) continue;
        if (p[i].a.cross(p[j].a).norm() <= sin_collinear || p[i].b.cross(p[j].b).norm() <= sin_collinear)
          continue;
        Quaterniond q(triad(p[i].b, p[j].b) * triad(p[i].a, p[j].a).transpose());
        set.add(q.normalized(), p, chord, need_all);
      }
  }
  // Best first; drop repeats of a kept rotation; polish the kept ones (least-squares angle about
  // their axis over the satisfied pairings) unless already exact.
  std::sort(set.h.begin(), set.h.begin() + set.n, hyp_better);
  int nout = 0;
  for (int k = 0; k < set.n; ++k) {
    const Hyp& h = set.h[k];
    if (h.s < min_s) break;
    bool repeat = false;
    for (int r = 0; r < nout && !repeat; ++r) repeat = std::abs(out[r].q.coeffs().dot(h.q.coeffs())) >= cos_half_tol;
    if (repeat) continue;
    Hyp& o = out[nout++];
    o = h;
    if (o.rms <= 1e-12) continue;
    const Vector3d v = o.q.vec();
    const double vn = v.norm();
    if (vn <= kTiny) continue;
    Hyp polished;
    const Vector3d axis = v / vn;
    if (!rotation_about(p, axis_terms(axis), o.mask, axis, polished.q)) continue;
    if (polished.q.w() < 0) polished.q.coeffs() = -polished.q.coeffs();
    score(p, chord, polished, need_all);
    if (polished.s >= o.s && polished.rms <= o.rms) o = polished;
  }
  return nout;
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

// max_cross(x, y, u) <= s, decided on the squared norms (no square roots) unless they lie within
// rounding of s^2, where max_cross itself decides.
bool within_cross(const Vector3d& x, const Vector3d& y, const Vector3d* u, double s) {
  double m2 = x.cross(y).squaredNorm();
  if (u) m2 = std::max({m2, x.cross(*u).squaredNorm(), y.cross(*u).squaredNorm()});
  const double s2 = s * s;
  if (m2 > s2 * (1.0 + 1e-9)) return false;
  if (m2 < s2 * (1.0 - 1e-9)) return true;
  return max_cross(x, y, u) <= s;
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
  const detail::VersorSettings settings =
      detail::versor_settings(options.angle_tolerance, options.collinear_tolerance, options.min_agreement);
  std::array<detail::VersorCandidate, detail::kMaxVersorCandidates> ranked;
  int nr = 0;
  const int status = detail::solve_versors(gp0, gp1, gn0, gn1, tp0, tp1, tn0, tn1, settings, ranked, nr);
  if (status == 1) {
    result.status = PairPoseStatus::Underdetermined;
    return;
  }
  if (status == 2) {
    result.status = PairPoseStatus::NoAgreement;
    return;
  }
  const Vector3d pg = 0.5 * (gp0 + gp1), pt = 0.5 * (tp0 + tp1);
  result.status = PairPoseStatus::Ok;
  result.candidates.resize(nr);
  for (int r = 0; r < nr; ++r) {
    PairPoseCandidate& c = result.candidates[r];
    const Quaterniond& q = ranked[r].q;
    c.versor = q;
    c.rotation = q.toRotationMatrix();
    c.translation = pt - c.rotation * pg;  // eq. 19
    const double vn = q.vec().norm();
    c.angle = 2.0 * std::atan2(vn, q.w());
    c.axis = vn > 0 ? Vector3d(q.vec() / vn) : Vector3d::UnitZ();
    canonicalize_versor(c.angle, c.axis);
    c.agreement = ranked[r].s * (ranked[r].s - 1) / 2;
    c.order = ranked[r].order;
    c.residual = ranked[r].rms;
  }
}

namespace detail {

static_assert(kMaxVersorCandidates >= 2 * kMaxHyp, "room for both orders' hypotheses");

VersorSettings versor_settings(double angle_tolerance, double collinear_tolerance, int min_agreement) {
  VersorSettings s;
  s.sin_collinear = std::sin(std::min(collinear_tolerance, 0.5 * kPi));
  // Agreement s(s-1)/2 >= min_agreement  <=>  s >= min_s.
  s.min_s = min_agreement <= 1 ? 2 : 3;
  const double tol = std::min(angle_tolerance, kPi);
  s.chord = 2.0 * std::sin(0.5 * tol);
  s.cos_half_tol = std::cos(0.5 * tol);  // |q1.q2| >= this  <=>  angle(q1, q2) <= tol
  return s;
}

int solve_versors(const Vector3d& gp0, const Vector3d& gp1, const Vector3d& gn0, const Vector3d& gn1,
                  const Vector3d& tp0, const Vector3d& tp1, const Vector3d& tn0, const Vector3d& tn1,
                  const VersorSettings& settings, std::array<VersorCandidate, kMaxVersorCandidates>& out,
                  int& count, unsigned orders) {
  count = 0;
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
  const double sin_collinear = settings.sin_collinear;
  if (within_cross(a0, a1, has_u ? &ug : nullptr, sin_collinear) ||
      within_cross(tn0, tn1, has_u ? &ut : nullptr, sin_collinear))
    return 1;

  std::array<Ranked, 2 * kMaxHyp> ranked;
  int nr = 0;
  for (int order = 0; order < 2; ++order) {
    if (!(orders & (1u << order))) continue;
    std::array<Pairing, 3> p;
    p[0] = {a0, order == 0 ? tn0 : tn1, true};
    p[1] = {a1, order == 0 ? tn1 : tn0, true};
    p[2] = {ug, order == 0 ? ut : Vector3d(-ut), has_u};
    std::array<Hyp, kMaxHyp> hyps;
    const int nh = order_hypotheses(p, settings.chord, sin_collinear, settings.min_s, settings.cos_half_tol, hyps);
    for (int k = 0; k < nh; ++k) ranked[nr++] = {hyps[k], order};
  }
  if (nr == 0) return 2;
  std::sort(ranked.begin(), ranked.begin() + nr, better);
  for (int r = 0; r < nr; ++r) out[r] = {ranked[r].h.q, ranked[r].h.s, ranked[r].order, ranked[r].h.rms};
  count = nr;
  return 0;
}

}  // namespace detail

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
