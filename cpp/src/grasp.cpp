// Closing the fingers onto contact: closing directions and conservative advancement per DOF.
#include <pairgrasp/grasp.hpp>

#include <pairgrasp/error.hpp>

#include "collision_internal.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace pairgrasp {

namespace vd = geometry_detail;
using vd::Vec3;

const char* to_string(StopReason reason) {
  switch (reason) {
    case StopReason::Contact: return "contact";
    case StopReason::Limit: return "limit";
    case StopReason::Blocked: return "blocked";
    case StopReason::Fixed: return "fixed";
  }
  return "unknown";
}

Eigen::VectorXi closing_directions(const Hand& hand, const Eigen::VectorXd& dofs) {
  const std::vector<Pose> p0 = hand.link_poses(dofs);  // validates dofs
  const Eigen::VectorXd lo = hand.dof_lower(), hi = hand.dof_upper();
  const auto& links = hand.links();
  Eigen::VectorXi dirs = Eigen::VectorXi::Zero(dofs.size());
  for (Eigen::Index k = 0; k < dofs.size(); ++k) {
    const double range = hi[k] - lo[k];
    if (!(range > 0.0)) continue;
    const double delta = 1e-6 * range;
    const double sgn = dofs[k] + delta <= hi[k] ? 1.0 : -1.0;
    Eigen::VectorXd q1 = dofs;
    q1[k] += sgn * delta;
    const std::vector<Pose> p1 = hand.link_poses(q1, true);
    double num = 0.0, den = 0.0;
    for (std::size_t l = 0; l < links.size(); ++l) {
      const Mesh& m = links[l].mesh;
      for (int f : links[l].active_faces) {
        const Vec3 a = m.vertices.row(m.faces(f, 0)).transpose(), b = m.vertices.row(m.faces(f, 1)).transpose(),
                   c = m.vertices.row(m.faces(f, 2)).transpose();
        const Vec3 cross = (b - a).cross(c - a);
        const double area = 0.5 * cross.norm();
        if (!(area > 0.0)) continue;
        const Vec3 centre = (a + b + c) / 3.0;
        const Vec3 v = (p1[l] * centre - p0[l] * centre) * (sgn / delta);  // per unit increase
        const Vec3 n = p0[l].linear() * cross.normalized();
        num += area * v.dot(n);
        den += area * v.norm();
      }
    }
    if (!(den > 0.0)) continue;
    const double score = num / den;
    dirs[k] = score >= 0.5 ? 1 : (score <= -0.5 ? -1 : 0);
  }
  return dirs;
}

namespace {

// How fast a link moves with DOF k at q: its largest vertex speed (m per unit of the DOF), and
// whether it turns (a link that only translates moves every point at that speed all along a step).
struct LinkSpeed {
  double speed = 0.0;
  bool turns = true;
};

std::vector<LinkSpeed> link_speeds(const Hand& hand, const std::vector<int>& links, const Eigen::VectorXd& q,
                                   Eigen::Index k, int dir, double lo, double hi) {
  const double delta = 1e-6 * (hi - lo);
  Eigen::VectorXd q1 = q;
  double step = dir * delta;
  if (q[k] + step > hi || q[k] + step < lo) step = -step;
  q1[k] += step;
  const std::vector<Pose> p0 = hand.link_poses(q), p1 = hand.link_poses(q1, true);
  std::vector<LinkSpeed> speeds;
  for (int l : links) {
    const Mesh& m = hand.links()[l].mesh;
    const Eigen::Matrix4d dm = p1[l].matrix() - p0[l].matrix();
    double v = 0.0;
    for (Eigen::Index i = 0; i < m.vertices.rows(); ++i) {
      const Vec3 x = m.vertices.row(i).transpose();
      v = std::max(v, (dm.topLeftCorner<3, 3>() * x + dm.topRightCorner<3, 1>()).norm());
    }
    // Turning by 1e-9 of the step or less: round-off of a translation.
    const bool turns = dm.topLeftCorner<3, 3>().cwiseAbs().maxCoeff() > 1e-9 * std::abs(step);
    speeds.push_back({v / std::abs(step), turns});
  }
  return speeds;
}

}  // namespace

CloseResult close_fingers(const GraspChecker& checker, const Pose& wrist, const Eigen::VectorXd& dofs,
                          const CloseOptions& options) {
  const detail::CheckerAccess::Impl& I = detail::CheckerAccess::impl(checker);
  const Hand& hand = I.hand;
  check_rigid(wrist, "wrist");
  const Eigen::Index D = static_cast<Eigen::Index>(hand.dofs().size());
  CloseResult r;
  if (options.measure) {
    r.start = checker.check(wrist, dofs);  // validates dofs
    r.start_penetrating = r.start.penetrating || r.start.obstacle_collision;
  } else {
    hand.link_poses(dofs);  // validates dofs
  }
  if (options.directions.size() > 0) {
    detail::check_size("directions", D, options.directions.size());
    for (Eigen::Index k = 0; k < D; ++k)
      if (std::abs(options.directions[k]) > 1)
        throw std::invalid_argument("directions[" + std::to_string(k) + "]: expected -1, 0 or +1, got " +
                                    std::to_string(options.directions[k]));
    r.directions = options.directions;
  } else {
    r.directions = closing_directions(hand, dofs);
  }
  if (options.max_iterations < 1)
    throw std::invalid_argument("max_iterations: expected >= 1, got " + std::to_string(options.max_iterations));

  const double gap = I.options.contact_gap;
  const double tol = I.options.depth_tolerance;
  const Eigen::VectorXd lo = hand.dof_lower(), hi = hand.dof_upper();
  Eigen::VectorXd q = dofs;
  r.reasons.assign(D, StopReason::Fixed);
  r.clearance = Eigen::VectorXd::Constant(D, std::numeric_limits<double>::infinity());

  // Links whose last closing left them certainly apart from the target and the obstacles (a
  // positive clearance measured at their final pose): the final check need not search their pairs.
  std::vector<char> apart(hand.links().size(), 0);
  for (Eigen::Index k = 0; k < D; ++k) {
    const int dir = r.directions[k];
    const std::vector<int>& moving = I.dof_links[k];
    if (dir == 0 || moving.empty()) continue;
    for (int l : moving) apart[l] = 0;

    // The distance of the moving links (each link's in `per_link`). With distance fields, a
    // lower bound of it beyond `above` (a conservative step, and the comparison with `above`
    // decided); the exact value below it (0 at once where the field shows the surfaces crossing).
    std::vector<double> per_link(moving.size());
    auto distance_at = [&](const Eigen::VectorXd& qq, bool active, double above) {
      const std::vector<Pose> poses = I.target_frame_poses(wrist, qq);
      double d = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < moving.size(); ++i) {
        per_link[i] = I.link_clearance(moving[i], poses[moving[i]], active, above);
        d = std::min(d, per_link[i]);
        if (d <= 0.0) break;
      }
      ++r.iterations;
      return d;
    };

    // Links already penetrating (beyond the tolerance) or in an obstacle cannot move.
    {
      const std::vector<Pose> poses = I.target_frame_poses(wrist, q);
      bool blocked = false;
      for (int l : moving)
        for (std::size_t s = 0; s < I.scene.size() && !blocked; ++s) {
          // Only "beyond the tolerance" matters here: the depth search may stop there.
          const vd::PairCheck pc = I.pair(l, poses[l], static_cast<int>(s), I.scene[s].obstacle ? 0.0 : tol, I.scene[s].obstacle);
          if ((pc.intersecting || pc.inside) && (I.scene[s].obstacle || pc.depth > tol)) blocked = true;
        }
      if (blocked) {
        r.reasons[k] = StopReason::Blocked;
        r.clearance[k] = 0.0;
        continue;
      }
    }

    const double limit = dir > 0 ? hi[k] : lo[k];
    const double min_step = 1e-3 * (hi[k] - lo[k]);
    // A finger stops within half the gap (aiming at a quarter of it), so that the active-surface
    // samples of a face parallel to the target register as contacts (within the gap).
    const double stop = 0.5 * gap;
    double d = distance_at(q, false, stop);
    int iterations = 0;
    StopReason reason = StopReason::Blocked;
    while (true) {
      if (d <= stop) {
        // Contact when the field shows an active face within the gap; otherwise measured.
        bool within = false;
        const std::vector<Pose> poses = I.target_frame_poses(wrist, q);
        for (std::size_t i = 0; i < moving.size() && !within; ++i) within = I.active_within(moving[i], poses[moving[i]], gap);
        reason = within || distance_at(q, true, gap) <= gap ? StopReason::Contact : StopReason::Blocked;
        break;
      }
      if (q[k] == limit) {
        reason = StopReason::Limit;
        break;
      }
      if (++iterations > options.max_iterations) {
        reason = StopReason::Blocked;
        break;
      }
      // Each link's own distance over its own speed: a link near the joint moves slower than the
      // fingertip, so its distance allows a longer step. A turning link's speed changes along the
      // step (a third is kept in hand); a translating link's does not, so its step ends no nearer
      // than a quarter of the gap, since its distance is a lower bound.
      const std::vector<LinkSpeed> v = link_speeds(hand, moving, q, k, dir, lo[k], hi[k]);
      double step = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < moving.size(); ++i)
        if (v[i].speed > 0.0)
          step = std::min(step, (per_link[i] - 0.25 * gap) / ((v[i].turns ? 1.5 : 1.0) * v[i].speed));
      step = std::max(step, min_step);
      Eigen::VectorXd q_new = q;
      q_new[k] = dir > 0 ? std::min(q[k] + step, limit) : std::max(q[k] - step, limit);
      const double d_new = distance_at(q_new, false, stop);
      if (d_new > 0.0) {
        q = q_new;
        d = d_new;
        continue;
      }
      // The step ends intersecting: bisect between the last free value and it.
      double a = q[k], b = q_new[k], da = d;
      for (int it = 0; it < 60 && da > stop; ++it) {
        Eigen::VectorXd qm = q;
        qm[k] = 0.5 * (a + b);
        const double dm = distance_at(qm, false, stop);
        if (dm > 0.0) {
          a = qm[k];
          da = dm;
        } else {
          b = qm[k];
        }
      }
      q[k] = a;
      d = da;
      if (d > stop) {  // could not get within half the gap without intersecting (a gap of ~0)
        reason = StopReason::Contact;
        break;
      }
    }
    r.reasons[k] = reason;
    // d: the moving links' clearance at q, measured there (a certain lower bound, 0 when touching).
    if (d > 0.0)
      for (int l : moving) apart[l] = 1;
    if (options.measure && I.options.use_distance_field && d > stop) {  // maybe a lower bound: measure it
      const std::vector<Pose> poses = I.target_frame_poses(wrist, q);
      d = std::numeric_limits<double>::infinity();
      for (int l : moving) d = std::min(d, I.link_distance(l, poses[l], false));
    }
    r.clearance[k] = d;
  }
  r.dofs = q;
  r.check = I.check_poses(I.target_frame_poses(wrist, q), true, &apart);
  return r;
}

}  // namespace pairgrasp
