// closing_push(): how squarely each closing DOF pushes into the surface and is pushed back.
#include <pairgrasp/grasp.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace pairgrasp {

using Vec3 = Eigen::Vector3d;

ClosingPush closing_push(const Hand& hand, const Pose& wrist, const Eigen::VectorXd& dofs, const Contacts& contacts) {
  const Eigen::VectorXi dirs = closing_directions(hand, dofs);  // validates dofs
  const std::vector<Pose> p0 = hand.link_poses(dofs);
  const Eigen::VectorXd lo = hand.dof_lower(), hi = hand.dof_upper();
  const Eigen::Index C = contacts.points.rows();
  const Pose to_wrist = wrist.inverse();
  double worst = 2.0, least_drive = 2.0;
  for (Eigen::Index k = 0; k < dofs.size(); ++k) {
    if (dirs[k] == 0) continue;
    const double delta = 1e-6 * (hi[k] - lo[k]);
    double step = dirs[k] * delta;
    if (dofs[k] + step > hi[k] || dofs[k] + step < lo[k]) step = -step;  // at a limit: the motion's direction is the same
    Eigen::VectorXd q1 = dofs;
    q1[k] += step;
    const std::vector<Pose> p1 = hand.link_poses(q1, true);
    Vec3 push = Vec3::Zero();
    double weight = 0.0, drive = -1.0;
    std::vector<char> moved(static_cast<std::size_t>(C), 0);
    for (Eigen::Index c = 0; c < C; ++c) {
      const int l = contacts.links[static_cast<std::size_t>(c)];
      const Vec3 x = to_wrist * Vec3(contacts.points.row(c).transpose());
      Vec3 v = wrist.linear() * (p1[l] * (p0[l].inverse() * x) - x);
      const double speed = v.norm();
      if (!(speed > 1e-6 * std::abs(step))) continue;  // a link the DOF does not move: round-off only
      moved[static_cast<std::size_t>(c)] = 1;
      v *= (step * dirs[k] > 0 ? 1.0 : -1.0) / speed;  // unit closing motion
      const Vec3 in = -contacts.normals.row(c).transpose();
      push += in * std::max(0.0, in.dot(v));
      weight += std::max(0.0, in.dot(v));
      drive = std::max(drive, in.dot(v));
    }
    if (!(weight > 0.0)) continue;  // it pushes into none of its contacts (closing away from them)
    least_drive = std::min(least_drive, drive);
    // Its own contacts balance one another as far as their pushes cancel (a parallel jaw's two pads
    // move with one DOF); the others push back as squarely as their best normal.
    double best = 1.0 - push.norm() / weight;
    if (!(push.norm() > 1e-12 * weight)) {
      worst = std::min(worst, best);
      continue;
    }
    const Vec3 back = -push.normalized();
    for (Eigen::Index c = 0; c < C; ++c)
      if (!moved[static_cast<std::size_t>(c)]) best = std::max(best, -contacts.normals.row(c).dot(back));
    worst = std::min(worst, best);
  }
  ClosingPush out;
  if (worst <= 1.5) out.opposition = worst;
  if (least_drive <= 1.5) out.drive = least_drive;
  return out;
}

}  // namespace pairgrasp
