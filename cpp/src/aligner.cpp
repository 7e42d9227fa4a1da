// The Aligner: pass 1 correspondences, pass 2 rotation votes, pass 3 position votes
// (see aligner.hpp for the method, the variance and the determinism guarantees).
#include <pairgrasp/aligner.hpp>
#include <pairgrasp/error.hpp>
#include <pairgrasp/features.hpp>
#include <pairgrasp/versor.hpp>

#include "accumulator.hpp"
#include "aligner_internal.hpp"
#include "thread_pool.hpp"
#include "versor_core.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

namespace pairgrasp {

namespace detail {

double reference_spacing(const PairIndex& index) {
  const double h = index.spacing();
  return h > 0 && std::isfinite(h) ? h : index.d_max() / 10;
}

void check_constellation(const Points& points, const Points& normals) {
  if (points.rows() < 2)
    throw std::invalid_argument("points: expected (P,3) with P >= 2, got (" + std::to_string(points.rows()) + ",3)");
  if (normals.rows() != points.rows())
    throw std::invalid_argument("normals: expected (" + std::to_string(points.rows()) + ",3) like points, got (" +
                                std::to_string(normals.rows()) + ",3)");
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    if (!points.row(i).allFinite())
      throw std::invalid_argument("points: row " + std::to_string(i) + " is not finite");
    if (!normals.row(i).allFinite())
      throw std::invalid_argument("normals: row " + std::to_string(i) + " is not finite");
    const double n = normals.row(i).norm();
    if (!(std::abs(n - 1.0) <= 1e-6))
      throw std::invalid_argument("normals: row " + std::to_string(i) + " has length " + std::to_string(n) +
                                  ", expected unit length");
  }
}

}  // namespace detail

namespace {

using detail::check_constellation;
using detail::reference_spacing;

using Eigen::Quaterniond;
using Eigen::Vector3d;

constexpr double kPi = 3.14159265358979323846;
constexpr std::size_t kChunk = 256;  // correspondences per pass-2 work item (fixed: determinism)

struct GripperPair {
  std::int32_t a, b;
};

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point& t) {
  const Clock::time_point now = Clock::now();
  const double ms = std::chrono::duration<double, std::milli>(now - t).count();
  t = now;
  return ms;
}

// Pre-filter verdicts: solve both point orders, only order 0, only order 1, or reject (counted as
// the solver would count it).
enum : std::uint8_t { kSolve = 3, kOrder0 = 1, kOrder1 = 2, kUnderdetermined = 4, kNoAgreement = 8 };
constexpr std::uint8_t kOrders = 3;  // a verdict & kOrders != 0: solve those orders

constexpr double kGeometryMargin = 5e-4;  // int16 storage (5e-5 rad), float32 and double rounding
constexpr float kPiF = 3.14159265358979f;
constexpr float kAngleUnit = kPiF / float(PairIndex::kGeometryScale);  // radians per stored angle step
constexpr float kTripleUnit = 1.0f / float(PairIndex::kGeometryScale);
constexpr int kStoredMin = std::numeric_limits<std::int16_t>::min();  // the range of a stored value
constexpr int kStoredMax = std::numeric_limits<std::int16_t>::max();

// A stored angle decoded, in the float arithmetic every pre-filter condition is written in.
float stored_angle(int v) { return float(v) * kAngleUnit; }

// A closed range of stored int16 values (empty when lo > hi).
struct Range {
  int lo = 1, hi = 0;
  bool has(int v) const { return v >= lo && v <= hi; }
};

// Smallest stored value v with pred(v), for pred false then true over the stored range
// (kStoredMax + 1: none).
template <class Pred>
int first_true(Pred pred) {
  int a = kStoredMin, b = kStoredMax + 1;
  while (a < b) {
    const int m = a + (b - a) / 2;
    if (pred(m)) b = m;
    else a = m + 1;
  }
  return a;
}

// The stored values v with |value(v)| <= m, for value(v) monotone in v (float arithmetic, as the
// conditions were written on decoded angles): an interval, found by two bisections.
template <class Value>
Range within(Value value, float m, bool increasing) {
  Range r;
  if (increasing) {
    r.lo = first_true([&](int v) { return value(v) >= -m; });
    r.hi = first_true([&](int v) { return value(v) > m; }) - 1;
  } else {
    r.lo = first_true([&](int v) { return value(v) <= m; });
    r.hi = first_true([&](int v) { return value(v) < -m; }) - 1;
  }
  return r;
}

// The pre-filter's view of one gripper pair (see "Pre-filter" in aligner.hpp): A_0 = -n_a,
// A_1 = -n_b, A_2 = u = (p_b - p_a) / |p_b - p_a|, with the angles phi (A_0, A_1), b0 (A_0, u),
// b1 (A_1, u) and tri = det(A_0, A_1, u). A stored target pair (angles phi', bi, bj, triple
// product tri', decoded from int16) can give a voting candidate of order 0 when |phi - phi'|,
// |b0 - bi| and |b1 - bj| are at most the angle margin and |tri - tri'| at most its own, and of
// order 1 when the same holds with bi, bj replaced by pi - bj, pi - bi. Each condition bounds one
// stored value, so it is kept as the range of int16 values that satisfy it (the same float
// arithmetic, evaluated once per gripper pair), and a verdict is a few integer comparisons.
struct GripperAngles {
  Range phi, tri;   // stored phi', tri' that pass
  Range bi0, bj0;   // order 0: stored bi, bj
  Range bi1, bj1;   // order 1: stored bi (against b1), bj (against b0)
  bool usable = false;  // the pre-filter may reject this pair's correspondences
};

// The pre-filter's constants for one alignment.
struct Prefilter {
  bool on = false;
  float angle_margin = 0;  // 2 tau + margin (radians)
  float tri_margin = 0;    // c(1+c)^2 + c(1+c) + c + margin
  float min_d = 0;         // shorter target pairs are solved (the solver may drop their line pairing)
  // The collinearity angle min(x, pi - x) of a stored angle x is at most col_lo (clearly below the
  // collinear tolerance) for stored values <= near0 or >= near_pi, and above col_hi (clearly
  // above it) for stored values in `far`.
  int near0 = 0, near_pi = 0;
  Range far;
};

GripperAngles gripper_ranges(const Prefilter& pf, float phi, float b0, float b1, float tri) {
  const float m = pf.angle_margin;
  GripperAngles ga;
  ga.phi = within([&](int v) { return phi - stored_angle(v); }, m, false);
  ga.tri = within([&](int v) { return tri - float(v) * kTripleUnit; }, pf.tri_margin, false);
  ga.bi0 = within([&](int v) { return b0 - stored_angle(v); }, m, false);
  ga.bj0 = within([&](int v) { return b1 - stored_angle(v); }, m, false);
  ga.bj1 = within([&](int v) { return b0 - (kPiF - stored_angle(v)); }, m, true);
  ga.bi1 = within([&](int v) { return b1 - (kPiF - stored_angle(v)); }, m, true);
  ga.usable = true;
  return ga;
}

// Verdict on a target pair (its feature f, geometry g) for a gripper pair's ranges.
inline std::uint8_t prefilter_verdict(const Prefilter& pf, const GripperAngles& ga, const float* f,
                                      const std::int16_t* g) {
  if (!(f[0] > pf.min_d)) return kSolve;
  const int phi = g[0], bi = g[1], bj = g[2];
  if (ga.phi.has(phi) && ga.tri.has(g[3])) {
    const std::uint8_t orders = static_cast<std::uint8_t>((ga.bi0.has(bi) && ga.bj0.has(bj) ? kOrder0 : 0) |
                                                          (ga.bi1.has(bi) && ga.bj1.has(bj) ? kOrder1 : 0));
    if (orders) return orders;
  }
  // As the solver would count it: underdetermined when the target side is collinear,
  // max(|n_i x n_j|, |n_i x u|, |n_j x u|) <= sin(collinear_tolerance), i.e. when each of the
  // three angles lies within collinear_tolerance (<= pi/2) of 0 or pi.
  auto near = [&](int v) { return v <= pf.near0 || v >= pf.near_pi; };
  if (near(phi) && near(bi) && near(bj)) return kUnderdetermined;
  if (pf.far.has(phi) || pf.far.has(bi) || pf.far.has(bj)) return kNoAgreement;
  return kSolve;
}

// One solver candidate that voted: 28 bytes.
struct Vote {
  std::uint32_t corr;   // index into the correspondence list
  std::int32_t slot;    // rotation bin, -1 when dropped
  float q[4];           // canonical quaternion (x, y, z, w)
  std::uint8_t agreement;
  std::uint8_t order;
};

struct Correspondence {
  std::uint32_t gripper_pair;
  std::uint32_t target_pair;
  std::uint8_t orders = kSolve;  // the point orders that can give a voting candidate
};

Quaterniond vote_quaternion(const Vote& v) {
  return Quaterniond(v.q[3], v.q[0], v.q[1], v.q[2]).normalized();
}

void check_tolerance(const char* name, double v) {
  if (!std::isfinite(v) || v < 0)
    throw std::invalid_argument(std::string(name) + ": expected a non-negative finite value (0: default), got " +
                                std::to_string(v));
}

// Everything one alignment needs, read-only.
struct Context {
  const PairIndex& index;
  const AlignerOptions& opt;  // resolved
  const Points& gp;
  const Points& gn;
  double h;
};

Vector3d gripper_mid(const Context& c, const GripperPair& g) {
  return 0.5 * (c.gp.row(g.a).transpose() + c.gp.row(g.b).transpose());
}

Vector3d target_mid(const Context& c, std::uint32_t target_pair) {
  const auto& pairs = c.index.pairs();
  const auto& tp = c.index.points();
  return 0.5 * (tp.row(pairs(target_pair, 0)).transpose() + tp.row(pairs(target_pair, 1)).transpose());
}

// Turns the votes of one (rotation, position) cluster into a pose (without its contacts; see
// add_contacts). `seed` is the rotation cluster's mean; returns false when fewer than min_votes
// remain. `kept`: the votes that support the pose.
bool make_pose(const Context& c, const std::vector<GripperPair>& gpairs, const std::vector<Correspondence>& corr,
               const std::vector<Vote>& votes, const std::vector<std::uint32_t>& members, const Quaterniond& seed,
               AlignedPose& pose, std::vector<std::uint32_t>& kept) {
  const double tau = c.opt.angle_tolerance;
  // Weighted mean quaternion, signs aligned to the seed; once more without the outliers.
  auto mean_of = [&](const Quaterniond& ref, const std::vector<std::uint32_t>& which) {
    Eigen::Vector4d sum = Eigen::Vector4d::Zero();
    for (auto k : which) {
      const Quaterniond q = vote_quaternion(votes[k]);
      const double w = votes[k].agreement;
      sum += (q.coeffs().dot(ref.coeffs()) < 0 ? -w : w) * q.coeffs();
    }
    Quaterniond m;
    m.coeffs() = sum.normalized();
    return m;
  };
  Quaterniond mean = mean_of(seed, members);
  kept.clear();
  kept.reserve(members.size());
  for (auto k : members)
    if (rotation_distance(vote_quaternion(votes[k]), mean) <= tau) kept.push_back(k);
  if (kept.empty()) kept = members;
  mean = mean_of(mean, kept);
  const Eigen::Matrix3d R = mean.toRotationMatrix();

  double wsum = 0.0;
  Vector3d tsum = Vector3d::Zero();
  for (auto k : kept) {
    const Vote& v = votes[k];
    const double w = v.agreement;
    const Correspondence& cr = corr[v.corr];
    tsum += w * (target_mid(c, cr.target_pair) - R * gripper_mid(c, gpairs[cr.gripper_pair]));
    wsum += w;
  }
  const int total_votes = static_cast<int>(std::lround(wsum));
  if (total_votes < c.opt.min_votes) return false;
  const Vector3d t = tsum / wsum;

  double pos2 = 0.0, ang2 = 0.0;
  for (auto k : kept) {
    const Vote& v = votes[k];
    const double w = v.agreement;
    const Correspondence& cr = corr[v.corr];
    const GripperPair& g = gpairs[cr.gripper_pair];
    pos2 += w * (target_mid(c, cr.target_pair) - R * gripper_mid(c, g) - t).squaredNorm();
    const double a = rotation_distance(vote_quaternion(v), mean);
    ang2 += w * a * a;
  }

  pose.rotation = R;
  pose.translation = t;
  pose.votes = total_votes;
  pose.position_rms = std::sqrt(pos2 / wsum);
  pose.angle_rms = std::sqrt(ang2 / wsum);
  pose.variance = pos2 / wsum / (c.h * c.h) + ang2 / wsum / (tau * tau);
  pose.quality = total_votes / (1.0 + pose.variance);
  pose.correspondences = static_cast<int>(kept.size());
  return true;
}

// The matched contacts of a pose from the votes that support it: (gripper sample, target point)
// of both pairings of each vote, deduplicated and sorted.
void add_contacts(const Context& c, const std::vector<GripperPair>& gpairs, const std::vector<Correspondence>& corr,
                  const std::vector<Vote>& votes, const std::vector<std::uint32_t>& kept, AlignedPose& pose) {
  std::vector<std::pair<std::int32_t, std::int32_t>> contacts;
  contacts.reserve(2 * kept.size());
  const auto& pairs = c.index.pairs();
  for (auto k : kept) {
    const Vote& v = votes[k];
    const Correspondence& cr = corr[v.corr];
    const GripperPair& g = gpairs[cr.gripper_pair];
    const std::int32_t i = pairs(cr.target_pair, 0), j = pairs(cr.target_pair, 1);
    contacts.emplace_back(g.a, v.order == 0 ? i : j);
    contacts.emplace_back(g.b, v.order == 0 ? j : i);
  }
  std::sort(contacts.begin(), contacts.end());
  contacts.erase(std::unique(contacts.begin(), contacts.end()), contacts.end());
  pose.contacts.resize(static_cast<Eigen::Index>(contacts.size()), 2);
  for (std::size_t r = 0; r < contacts.size(); ++r) {
    pose.contacts(static_cast<Eigen::Index>(r), 0) = contacts[r].first;
    pose.contacts(static_cast<Eigen::Index>(r), 1) = contacts[r].second;
  }
}

AlignResult align_impl(const PairIndex& index, const AlignerOptions& opt, const Points& gp, const Points& gn,
                       int threads) {
  check_constellation(gp, gn);
  AlignResult result;
  AlignStats& st = result.stats;
  const Context ctx{index, opt, gp, gn, reference_spacing(index)};
  const double tau = opt.angle_tolerance;
  Clock::time_point clock = Clock::now();

  // ---- pass 1: correspondences
  const auto P = static_cast<std::int32_t>(gp.rows());
  std::vector<GripperPair> gpairs;
  std::vector<Vector3d> features;
  const double sin_collinear = std::sin(std::min(opt.collinear_tolerance, 0.5 * kPi));
  for (std::int32_t a = 0; a < P; ++a)
    for (std::int32_t b = a + 1; b < P; ++b) {
      const Vector3d pa = gp.row(a).transpose(), pb = gp.row(b).transpose();
      const Vector3d na = -gn.row(a).transpose(), nb = -gn.row(b).transpose();  // flipped
      const Vector3d d = pb - pa;
      const double len = d.norm();
      double s = na.cross(nb).norm();
      if (len > 0) s = std::max({s, na.cross(d / len).norm(), nb.cross(d / len).norm()});
      if (s <= sin_collinear) {
        ++st.collinear_pairs;
        continue;
      }
      if (len > index.d_max() + opt.feature_tolerance.x()) continue;  // nothing stored that far
      gpairs.push_back({a, b});
      features.push_back(pair_feature(pa, na, pb, nb));
    }
  st.gripper_pairs = static_cast<std::size_t>(P) * static_cast<std::size_t>(P - 1) / 2;

  // Pre-filter constants and each gripper pair's angles.
  Prefilter pf;
  std::vector<GripperAngles> gangles(gpairs.size());
  if (opt.prefilter && opt.min_agreement >= 2 && index.size() > 0) {
    pf.on = true;
    const double c = 2.0 * std::sin(0.5 * std::min(tau, kPi));
    pf.angle_margin = static_cast<float>(2.0 * std::min(tau, kPi) + kGeometryMargin);
    pf.tri_margin = static_cast<float>(c * (1 + c) * (1 + c) + c * (1 + c) + c + kGeometryMargin);
    const double collinear = std::min(opt.collinear_tolerance, 0.5 * kPi);
    const float col_lo = static_cast<float>(collinear - kGeometryMargin);
    const float col_hi = static_cast<float>(collinear + kGeometryMargin);
    // min(x, pi - x) <= col_lo  <=>  x <= col_lo or pi - x <= col_lo; > col_hi  <=>  both above.
    pf.near0 = first_true([&](int v) { return stored_angle(v) > col_lo; }) - 1;
    pf.near_pi = first_true([&](int v) { return kPiF - stored_angle(v) <= col_lo; });
    pf.far.lo = first_true([&](int v) { return stored_angle(v) > col_hi; });
    pf.far.hi = first_true([&](int v) { return kPiF - stored_angle(v) <= col_hi; }) - 1;
    // The solver drops the line pairing when |d| <= 1e-9 (1 + the largest coordinate).
    const double scale = 1.0 + std::max(gp.cwiseAbs().maxCoeff(), index.points().cwiseAbs().maxCoeff());
    pf.min_d = static_cast<float>(4e-9 * scale);
    for (std::size_t g = 0; g < gpairs.size(); ++g) {
      const Vector3d pa = gp.row(gpairs[g].a).transpose(), pb = gp.row(gpairs[g].b).transpose();
      const Vector3d a0 = -gn.row(gpairs[g].a).transpose(), a1 = -gn.row(gpairs[g].b).transpose();
      const Vector3d d = pb - pa;
      const double len = d.norm();
      if (!(len > 4e-9 * scale)) continue;
      const Vector3d u = d / len;
      const double col = std::max({a0.cross(a1).norm(), a0.cross(u).norm(), a1.cross(u).norm()});
      if (!(col > sin_collinear + kGeometryMargin)) continue;  // the solver's own test decides
      auto angle = [](double cosine) { return static_cast<float>(std::acos(std::clamp(cosine, -1.0, 1.0))); };
      gangles[g] = gripper_ranges(pf, angle(a0.dot(a1)), angle(a0.dot(u)), angle(a1.dot(u)),
                                  static_cast<float>(a0.cross(a1).dot(u)));
    }
  }
  std::vector<std::vector<std::uint32_t>> hits(gpairs.size());
  detail::parallel_for(gpairs.size(), threads, [&](std::size_t g) { index.query(features[g], opt.feature_tolerance, hits[g]); });
  for (const auto& h : hits) st.correspondences += h.size();
  result.times.query = ms_since(clock);
  const std::size_t stride =
      st.correspondences > opt.max_correspondences
          ? (st.correspondences + opt.max_correspondences - 1) / opt.max_correspondences
          : 1;
  // Verdicts per gripper pair; without thinning the rejected pairs leave the lists, the survivors
  // keeping query()'s increasing order.
  const float* tfeat = index.features().data();
  const std::int16_t* tgeom = index.pair_geometry().data();
  auto verdict = [&](std::size_t g, std::uint32_t t) {
    return prefilter_verdict(pf, gangles[g], tfeat + 3 * std::size_t(t), tgeom + 4 * std::size_t(t));
  };
  std::vector<std::size_t> g_under(gpairs.size(), 0), g_none(gpairs.size(), 0);
  // A survivor's orders travel in the two low bits of its id (ids below 2^30), which keeps the
  // ids' order and spares the verdict's second evaluation.
  const bool packed = pf.on && stride == 1 && index.size() < (std::size_t(1) << 30);
  detail::parallel_for(gpairs.size(), threads, [&](std::size_t g) {
    auto& h = hits[g];
    if (pf.on && stride == 1 && gangles[g].usable) {
      std::size_t keep = 0;
      for (std::size_t k = 0; k < h.size(); ++k) {
        const std::uint8_t v = verdict(g, h[k]);
        if (v & kOrders)
          h[keep++] = packed ? (h[k] << 2 | (v & kOrders)) : h[k];
        else if (v == kUnderdetermined)
          ++g_under[g];
        else
          ++g_none[g];
      }
      h.resize(keep);
    }
    // query() lists ids in increasing order; the survivors keep it (their orders ride below the id).
  });
  std::vector<Correspondence> corr;
  corr.reserve(st.correspondences / stride + 1);
  {
    std::size_t k = 0;
    for (std::size_t g = 0; g < hits.size(); ++g) {
      st.underdetermined += g_under[g];
      st.no_agreement += g_none[g];
      st.prefiltered += g_under[g] + g_none[g];
      const bool filter = pf.on && gangles[g].usable;
      for (auto t : hits[g]) {
        if (k++ % stride != 0) continue;
        std::uint8_t v = kSolve;
        if (filter && packed) {  // a survivor with its orders
          v = static_cast<std::uint8_t>(t & kOrders);
          t >>= 2;
        } else if (filter) {  // without thinning, hits[g] holds only survivors: v gives their orders
          v = verdict(g, t);
          if (!(v & kOrders)) {
            ++(v == kUnderdetermined ? st.underdetermined : st.no_agreement);
            ++st.prefiltered;
            continue;
          }
        }
        corr.push_back({static_cast<std::uint32_t>(g), t, v});
      }
      std::vector<std::uint32_t>().swap(hits[g]);
    }
  }
  st.correspondences_used = corr.size() + st.prefiltered;
  if (stride > 1) st.saturated = true;
  result.times.prefilter = ms_since(clock);

  // ---- pass 2: solve in fixed chunks (parallel), vote in chunk order (sequential)
  PairPoseOptions sopt;
  sopt.angle_tolerance = tau;
  sopt.collinear_tolerance = opt.collinear_tolerance;
  sopt.min_agreement = std::max(1, opt.min_agreement);
  const detail::VersorSettings vset =
      detail::versor_settings(sopt.angle_tolerance, sopt.collinear_tolerance, sopt.min_agreement);
  const std::size_t nchunks = (corr.size() + kChunk - 1) / kChunk;
  std::vector<std::vector<Vote>> chunk_votes(nchunks);
  std::vector<std::size_t> chunk_under(nchunks, 0), chunk_none(nchunks, 0);
  const auto& tpairs = index.pairs();
  const auto& tp = index.points();
  const auto& tn = index.normals();
  detail::parallel_for(nchunks, threads, [&](std::size_t ch) {
    auto& out = chunk_votes[ch];
    const std::size_t end = std::min(corr.size(), (ch + 1) * kChunk);
    if (!opt.prefilter) {
      // The solver as called before the pre-filter existed (kept for comparison).
      PairPoseResult r;
      for (std::size_t k = ch * kChunk; k < end; ++k) {
        const GripperPair& g = gpairs[corr[k].gripper_pair];
        const std::int32_t i = tpairs(corr[k].target_pair, 0), j = tpairs(corr[k].target_pair, 1);
        solve_pair_pose(gp.row(g.a).transpose(), gp.row(g.b).transpose(), gn.row(g.a).transpose(),
                        gn.row(g.b).transpose(), tp.row(i).transpose(), tp.row(j).transpose(), tn.row(i).transpose(),
                        tn.row(j).transpose(), sopt, r);
        if (r.status == PairPoseStatus::Underdetermined) ++chunk_under[ch];
        if (r.status == PairPoseStatus::NoAgreement) ++chunk_none[ch];
        for (const auto& c : r.candidates) {
          if (c.agreement < opt.min_agreement) continue;
          const Quaterniond q = detail::canonical_quaternion(c.versor);
          out.push_back({static_cast<std::uint32_t>(k), -1,
                         {float(q.x()), float(q.y()), float(q.z()), float(q.w())},
                         static_cast<std::uint8_t>(c.agreement), static_cast<std::uint8_t>(c.order)});
        }
      }
      return;
    }
    std::array<detail::VersorCandidate, detail::kMaxVersorCandidates> cand;
    for (std::size_t k = ch * kChunk; k < end; ++k) {
      const GripperPair& g = gpairs[corr[k].gripper_pair];
      const std::int32_t i = tpairs(corr[k].target_pair, 0), j = tpairs(corr[k].target_pair, 1);
      int n = 0;
      const int status = detail::solve_versors(gp.row(g.a).transpose(), gp.row(g.b).transpose(),
                                               gn.row(g.a).transpose(), gn.row(g.b).transpose(), tp.row(i).transpose(),
                                               tp.row(j).transpose(), tn.row(i).transpose(), tn.row(j).transpose(),
                                               vset, cand, n, corr[k].orders);
      if (status == 1) ++chunk_under[ch];
      if (status == 2) ++chunk_none[ch];
      for (int c = 0; c < n; ++c) {
        const int agreement = cand[c].s * (cand[c].s - 1) / 2;
        if (agreement < opt.min_agreement) continue;
        const Quaterniond q = detail::canonical_quaternion(cand[c].q);
        out.push_back({static_cast<std::uint32_t>(k), -1,
                       {float(q.x()), float(q.y()), float(q.z()), float(q.w())},
                       static_cast<std::uint8_t>(agreement), static_cast<std::uint8_t>(cand[c].order)});
      }
    }
  });
  std::vector<Vote> votes;
  {
    std::size_t n = 0;
    for (const auto& v : chunk_votes) n += v.size();
    votes.reserve(n);
    st.candidates = n;
    for (std::size_t ch = 0; ch < nchunks; ++ch) {
      votes.insert(votes.end(), chunk_votes[ch].begin(), chunk_votes[ch].end());
      std::vector<Vote>().swap(chunk_votes[ch]);
      st.underdetermined += chunk_under[ch];
      st.no_agreement += chunk_none[ch];
    }
  }
  result.times.solve = ms_since(clock);
  const double qcell = std::sin(0.25 * tau) * 2.0;  // chord of angle tau on the unit quaternions: 2 sin(tau / 4)
  detail::HashedBins<4> rbins(opt.capacity, votes.size());
  for (Vote& v : votes) {
    const Quaterniond q = vote_quaternion(v);
    st.rotation_votes += v.agreement;
    v.slot = rbins.add(detail::quaternion_cell(q, qcell), q.coeffs(), v.agreement);
  }
  st.rotation_bins = rbins.bins().size();
  st.dropped_rotation_votes = static_cast<std::size_t>(std::lround(rbins.dropped_weight()));
  if (rbins.saturated()) st.saturated = true;

  result.times.rotation_votes = ms_since(clock);

  // ---- pass 3: position votes for the strongest rotation clusters
  const auto rclusters = detail::rotation_clusters(rbins, qcell, tau, opt.rotation_clusters);
  st.rotation_clusters = rclusters.size();
  std::vector<std::int32_t> cluster_of(rbins.bins().size(), -1);
  for (std::size_t c = 0; c < rclusters.size(); ++c)
    for (auto b : rclusters[c].bins) cluster_of[b] = static_cast<std::int32_t>(c);
  std::vector<std::vector<std::uint32_t>> members(rclusters.size());
  for (std::size_t k = 0; k < votes.size(); ++k)
    if (votes[k].slot >= 0 && cluster_of[votes[k].slot] >= 0)
      members[cluster_of[votes[k].slot]].push_back(static_cast<std::uint32_t>(k));

  const double pcell = opt.position_tolerance;
  const Vector3d centroid = gp.colwise().mean().transpose();
  struct Made {
    AlignedPose pose;
    std::vector<std::uint32_t> kept;  // its votes, for the contacts of the poses returned
  };
  // Each rotation cluster's position votes and poses are its own (parallel over the clusters);
  // they are merged in cluster order, so the result does not depend on the thread count.
  struct ClusterOut {
    std::vector<Made> poses;
    std::size_t position_votes = 0, dropped = 0, bins = 0;
    bool saturated = false;
  };
  std::vector<ClusterOut> cluster_out(rclusters.size());
  detail::parallel_for(rclusters.size(), threads, [&](std::size_t c) {
    ClusterOut& co = cluster_out[c];
    Quaterniond qc;
    qc.coeffs() = rclusters[c].mean;
    detail::HashedBins<3> pbins(opt.position_capacity, members[c].size());
    std::vector<std::int32_t> pslot(members[c].size());
    for (std::size_t m = 0; m < members[c].size(); ++m) {
      // Where the vote puts the constellation's centroid: c_T = R_k c_G + t_k with
      // t_k = P_T - R_k P_G (eq. 19) and R_k the vote's own rotation. Clustering c_T rather than t
      // keeps the lever arm of a rotation error to the constellation's size (the wrist origin may
      // lie far from the contacts).
      const Vote& v = votes[members[c][m]];
      const Correspondence& cr = corr[v.corr];
      const Vector3d ct =
          target_mid(ctx, cr.target_pair) - vote_quaternion(v) * (gripper_mid(ctx, gpairs[cr.gripper_pair]) - centroid);
      co.position_votes += v.agreement;
      pslot[m] = pbins.add(detail::position_cell(ct, pcell), ct, v.agreement);
    }
    co.dropped = static_cast<std::size_t>(std::lround(pbins.dropped_weight()));
    co.bins = pbins.bins().size();
    co.saturated = pbins.saturated();
    const auto pclusters = detail::position_clusters(pbins, pcell, opt.position_tolerance, opt.positions_per_rotation);
    std::vector<std::int32_t> pcluster_of(pbins.bins().size(), -1);
    for (std::size_t p = 0; p < pclusters.size(); ++p)
      for (auto b : pclusters[p].bins) pcluster_of[b] = static_cast<std::int32_t>(p);
    std::vector<std::vector<std::uint32_t>> pmembers(pclusters.size());
    for (std::size_t m = 0; m < members[c].size(); ++m)
      if (pslot[m] >= 0 && pcluster_of[pslot[m]] >= 0) pmembers[pcluster_of[pslot[m]]].push_back(members[c][m]);
    for (std::size_t p = 0; p < pclusters.size(); ++p) {
      Made m;
      if (make_pose(ctx, gpairs, corr, votes, pmembers[p], qc, m.pose, m.kept)) co.poses.push_back(std::move(m));
    }
  });
  std::vector<Made> poses;
  for (ClusterOut& co : cluster_out) {
    st.position_votes += co.position_votes;
    st.dropped_position_votes += co.dropped;
    st.position_bins = std::max(st.position_bins, co.bins);
    if (co.saturated) st.saturated = true;
    for (Made& m : co.poses) poses.push_back(std::move(m));
  }

  // Best first; a pose within both tolerances of a better one repeats it and is dropped.
  std::stable_sort(poses.begin(), poses.end(), [](const Made& x, const Made& y) {
    if (x.pose.quality != y.pose.quality) return x.pose.quality > y.pose.quality;
    return x.pose.votes > y.pose.votes;
  });
  for (auto& m : poses) {
    if (static_cast<int>(result.poses.size()) >= opt.max_poses) break;
    const AlignedPose& p = m.pose;
    const Quaterniond qp(p.rotation);
    bool repeat = false;
    for (const auto& k : result.poses)
      repeat = repeat || (rotation_distance(Quaterniond(k.rotation), qp) <= tau &&
                          (k.translation - p.translation).norm() <= opt.position_tolerance);
    if (repeat) continue;
    add_contacts(ctx, gpairs, corr, votes, m.kept, m.pose);
    result.poses.push_back(std::move(m.pose));
  }
  result.times.positions = ms_since(clock);
  return result;
}

}  // namespace

Pose AlignedPose::pose() const {
  Pose p = Pose::Identity();
  p.linear() = rotation;
  p.translation() = translation;
  return p;
}

Aligner::Aligner(PairIndex index, const AlignerOptions& options)
    : index_(std::move(index)), options_(options) {
  AlignerOptions& o = options_;
  for (int k = 0; k < 3; ++k) check_tolerance("feature_tolerance", o.feature_tolerance[k]);
  check_tolerance("angle_tolerance", o.angle_tolerance);
  check_tolerance("position_tolerance", o.position_tolerance);
  check_tolerance("collinear_tolerance", o.collinear_tolerance);
  if (o.angle_tolerance >= kPi) throw std::invalid_argument("angle_tolerance: expected less than pi radians, got " +
                                                            std::to_string(o.angle_tolerance));
  if (o.capacity == 0) throw std::invalid_argument("capacity: expected at least 1 rotation bin, got 0");
  if (o.position_capacity == 0)
    throw std::invalid_argument("position_capacity: expected at least 1 position bin, got 0");
  if (o.max_correspondences == 0)
    throw std::invalid_argument("max_correspondences: expected at least 1, got 0");
  auto at_least_one = [](const char* name, int v) {
    if (v < 1) throw std::invalid_argument(std::string(name) + ": expected at least 1, got " + std::to_string(v));
  };
  at_least_one("rotation_clusters", o.rotation_clusters);
  at_least_one("positions_per_rotation", o.positions_per_rotation);
  at_least_one("max_poses", o.max_poses);
  if (o.min_agreement < 0 || o.min_agreement > 3)
    throw std::invalid_argument("min_agreement: expected 0..3, got " + std::to_string(o.min_agreement));
  if (o.min_votes < 0) throw std::invalid_argument("min_votes: expected >= 0, got " + std::to_string(o.min_votes));
  if (o.threads < 0) throw std::invalid_argument("threads: expected >= 0 (0: all cores), got " + std::to_string(o.threads));

  const double h = reference_spacing(index_);
  const Vector3d def(0.5 * h, 0.1, 0.1);
  for (int k = 0; k < 3; ++k)
    if (o.feature_tolerance[k] == 0) o.feature_tolerance[k] = def[k];
  if (o.angle_tolerance == 0) o.angle_tolerance = 4.0 * kPi / 180.0;
  if (o.position_tolerance == 0) o.position_tolerance = 0.5 * h;
  if (o.collinear_tolerance == 0) o.collinear_tolerance = o.angle_tolerance;
  check_tolerance("antipodal_cone", o.antipodal_cone);
  if (o.antipodal_cone == 0) o.antipodal_cone = kDefaultAntipodalCone;
  if (o.antipodal_cone >= kPi / 2)
    throw std::invalid_argument("antipodal_cone: expected less than pi/2 radians, got " + std::to_string(o.antipodal_cone));
  at_least_one("antipodal_rolls", o.antipodal_rolls);
}

const AlignerOptions& Aligner::options() const { return options_; }

const PairIndex& Aligner::index() const { return index_; }

AlignResult Aligner::align(const Points& points, const Points& normals) const {
  return align_impl(index_, options_, points, normals, detail::resolve_threads(options_.threads));
}

std::vector<AlignResult> Aligner::align_many(const std::vector<Constellation>& constellations, int max_poses) const {
  return detail::align_each(constellations, options_, max_poses, options_.threads, check_constellation,
                            [this](const Points& p, const Points& n, const AlignerOptions& o) {
                              return align_impl(index_, o, p, n, 1);
                            });
}

}  // namespace pairgrasp
