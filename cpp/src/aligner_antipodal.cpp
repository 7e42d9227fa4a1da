// The Aligner's antipodal alignment of a parallel jaw: grasp lines voted by the target's antipodal
// pairs, turned about (see "Antipodal alignment" in aligner.hpp).
#include <pairgrasp/aligner.hpp>

#include "aligner_internal.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <tuple>
#include <utility>

namespace pairgrasp {

namespace {

using Eigen::Vector3d;

constexpr double kPi = 3.14159265358979323846;
constexpr double kFacing = 0.95;  // the pads' normals along the line between them (cosine)
constexpr double kClosed = 1e-6;  // m: pads closer than this are closed and align nowhere

// One bin of grasp lines: its pairs (index positions in the query's list) and their sums.
struct LineBin {
  std::vector<std::uint32_t> members;
  Vector3d sum_m = Vector3d::Zero(), sum_t = Vector3d::Zero();
};

// A line of the target: unit direction t (canonical sign), midpoint m, and which pad the pair's
// first facet is under (false: pad a on facet i).
struct Line {
  std::uint32_t pair;
  Vector3d t, m;
  bool swapped;
};

double angle_between(const Vector3d& a, const Vector3d& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); }

void check_jaw(const Points& points, const Points& normals) {
  detail::check_constellation(points, normals);
  if (points.rows() != 2)
    throw std::invalid_argument("points: antipodal alignment takes the two pads' samples, expected (2,3), got (" +
                                std::to_string(points.rows()) + ",3)");
  const Vector3d a = points.row(0).transpose(), b = points.row(1).transpose();
  const double w = (b - a).norm();
  if (!(w > kClosed)) return;  // a closed jaw grasps nothing: no poses
  const Vector3d g = (b - a) / w;
  if (normals.row(0).dot(g) < kFacing || -normals.row(1).dot(g) < kFacing)
    throw std::invalid_argument("normals: the pads' normals do not face each other along the line between them");
}

// The feature box of the pairs a jaw open at w can close on: d in [0, w], phi = n_i.n_j <=
// -cos(2 cone), beta >= 2 cos(cone), with a little slack for the float32 features (the exact cone
// test follows the query). (centre, tolerance).
std::pair<Vector3d, Vector3d> antipodal_box(double w, double cone) {
  const double phi_hi = -std::cos(std::min(2 * cone, kPi)), cos_cone = std::cos(cone), slack = 1e-5;
  return {Vector3d(w / 2, (-1.0 + phi_hi) / 2, 1.0 + cos_cone),
          Vector3d(w / 2 + slack, (phi_hi + 1.0) / 2 + slack, 1.0 - cos_cone + slack)};
}

double width(const Points& gp) { return (gp.row(1) - gp.row(0)).norm(); }

AlignResult antipodal_impl(const PairIndex& index, const AlignerOptions& opt, const Points& gp) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point t0 = Clock::now();
  AlignResult result;
  AlignStats& st = result.stats;
  const Vector3d a = gp.row(0).transpose(), b = gp.row(1).transpose();
  const double w = width(gp);
  st.gripper_pairs = 1;
  if (!(w > kClosed)) return result;
  const Vector3d g = (b - a) / w, m_g = (a + b) / 2;
  const double cone = opt.antipodal_cone, cos_cone = std::cos(cone);
  const double tau = opt.angle_tolerance, pcell = opt.position_tolerance;
  const double h = detail::reference_spacing(index);

  const auto [centre, tolerance] = antipodal_box(w, cone);
  std::vector<std::uint32_t> found;
  index.query(centre, tolerance, found);
  st.correspondences = found.size();
  const Clock::time_point t1 = Clock::now();

  const auto& pairs = index.pairs();
  const Points& p = index.points();
  const Points& n = index.normals();
  std::vector<Line> lines;
  lines.reserve(found.size());
  for (const std::uint32_t k : found) {
    const Eigen::Index i = pairs(k, 0), j = pairs(k, 1);
    Vector3d u = (p.row(j) - p.row(i)).transpose();
    const double d = u.norm();
    if (!(d > 0.0) || d > w) continue;
    u /= d;
    if (-n.row(i).dot(u) < cos_cone || n.row(j).dot(u) < cos_cone) continue;
    // The line's direction: the pads close along the surface normals, so it is the mean of the
    // two (n_j - n_i, both outward), not u (on two parallel faces every tilted pair then votes
    // for the faces' normal). Canonical sign: the first coordinate not (nearly) zero is positive.
    Vector3d t = (n.row(j) - n.row(i)).transpose().normalized();
    const int axis = std::abs(t.x()) > 1e-9 ? 0 : std::abs(t.y()) > 1e-9 ? 1 : 2;
    const bool swapped = t[axis] < 0;
    if (swapped) t = -t;
    lines.push_back({k, t, (p.row(i) + p.row(j)).transpose() / 2, swapped});
  }
  st.correspondences_used = st.candidates = st.rotation_votes = lines.size();
  // In facet order, not the index's storage order (which follows its tree): the lines taken on
  // equal votes do not depend on which other pairs the index holds.
  std::sort(lines.begin(), lines.end(), [&](const Line& x, const Line& y) {
    return std::make_pair(pairs(x.pair, 0), pairs(x.pair, 1)) < std::make_pair(pairs(y.pair, 0), pairs(y.pair, 1));
  });

  // Bins by direction (angle_tolerance) and midpoint (position_tolerance), in first-seen order.
  std::map<std::array<std::int64_t, 6>, std::uint32_t> slot;
  std::vector<LineBin> bins;
  for (std::uint32_t l = 0; l < lines.size(); ++l) {
    const Line& ln = lines[l];
    std::array<std::int64_t, 6> key;
    for (int c = 0; c < 3; ++c) {
      key[c] = static_cast<std::int64_t>(std::floor(ln.t[c] / tau));
      key[3 + c] = static_cast<std::int64_t>(std::floor(ln.m[c] / pcell));
    }
    auto [it, fresh] = slot.emplace(key, static_cast<std::uint32_t>(bins.size()));
    if (fresh) bins.emplace_back();
    LineBin& bin = bins[it->second];
    bin.members.push_back(l);
    bin.sum_m += ln.m;
    bin.sum_t += ln.t;
  }
  st.rotation_bins = bins.size();
  std::vector<std::uint32_t> order(bins.size());
  for (std::uint32_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t x, std::uint32_t y) {
    return bins[x].members.size() > bins[y].members.size();  // ties: first seen first
  });

  // Lines best first, skipping one near a line already taken.
  std::vector<std::pair<Vector3d, Vector3d>> taken;  // (direction, midpoint)
  for (const std::uint32_t k : order) {
    if (static_cast<int>(taken.size()) >= opt.max_poses) break;
    const LineBin& bin = bins[k];
    const double votes = static_cast<double>(bin.members.size());
    const Vector3d m = bin.sum_m / votes;
    if (!(bin.sum_t.norm() > 0.0)) continue;
    const Vector3d t = bin.sum_t.normalized();
    bool near = false;
    for (const auto& [tt, mm] : taken)
      near = near || ((mm - m).norm() <= 4 * pcell && angle_between(tt, t) <= 2 * tau);
    if (near) continue;
    taken.emplace_back(t, m);
    double var_p = 0.0, var_a = 0.0;
    Eigen::Matrix<std::int32_t, Eigen::Dynamic, 2, Eigen::RowMajor> contacts(2 * bin.members.size(), 2);
    for (std::size_t q = 0; q < bin.members.size(); ++q) {
      const Line& ln = lines[bin.members[q]];
      var_p += (ln.m - m).squaredNorm();
      var_a += std::pow(angle_between(ln.t, t), 2);
      const std::int32_t i = pairs(ln.pair, 0), j = pairs(ln.pair, 1);
      contacts.row(2 * q) << 0, ln.swapped ? j : i;
      contacts.row(2 * q + 1) << 1, ln.swapped ? i : j;
    }
    // Deduplicated, sorted contacts.
    std::vector<std::pair<std::int32_t, std::int32_t>> cs;
    for (Eigen::Index r = 0; r < contacts.rows(); ++r) cs.emplace_back(contacts(r, 0), contacts(r, 1));
    std::sort(cs.begin(), cs.end());
    cs.erase(std::unique(cs.begin(), cs.end()), cs.end());
    contacts.resize(static_cast<Eigen::Index>(cs.size()), 2);
    for (std::size_t r = 0; r < cs.size(); ++r) contacts.row(static_cast<Eigen::Index>(r)) << cs[r].first, cs[r].second;

    AlignedPose pose;
    pose.votes = static_cast<int>(bin.members.size());
    pose.correspondences = pose.votes;
    pose.position_rms = std::sqrt(var_p / votes);
    pose.angle_rms = std::sqrt(var_a / votes);
    pose.variance = (var_p / (h * h) + var_a / (tau * tau)) / votes;
    pose.quality = votes / (1.0 + pose.variance);
    pose.contacts = contacts;
    const Eigen::Matrix3d r0 = Eigen::Quaterniond::FromTwoVectors(g, t).toRotationMatrix();
    for (int r = 0; r < opt.antipodal_rolls; ++r) {
      pose.rotation = Eigen::AngleAxisd(2 * kPi * r / opt.antipodal_rolls, t).toRotationMatrix() * r0;
      pose.translation = m - pose.rotation * m_g;
      result.poses.push_back(pose);
    }
  }
  st.rotation_clusters = st.position_votes = taken.size();
  result.times.query = std::chrono::duration<double, std::milli>(t1 - t0).count();
  result.times.positions = std::chrono::duration<double, std::milli>(Clock::now() - t1).count();
  return result;
}

}  // namespace

AlignResult Aligner::align_antipodal(const Points& points, const Points& normals) const {
  check_jaw(points, normals);
  return antipodal_impl(index_, options_, points);
}

std::size_t Aligner::antipodal_count(const Points& points, const Points& normals) const {
  check_jaw(points, normals);
  const double w = width(points);
  if (!(w > kClosed)) return 0;
  const auto [centre, tolerance] = antipodal_box(w, options_.antipodal_cone);
  return index_.count(centre, tolerance);
}

std::vector<AlignResult> Aligner::align_antipodal_many(const std::vector<Constellation>& constellations,
                                                       int max_poses) const {
  return detail::align_each(constellations, options_, max_poses, options_.threads, check_jaw,
                            [this](const Points& p, const Points&, const AlignerOptions& o) {
                              return antipodal_impl(index_, o, p);
                            });
}

}  // namespace pairgrasp
