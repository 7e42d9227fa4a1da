// closing_push(): how squarely each closing DOF pushes into the surface and is pushed back;
// closing_friction(): the friction its stall torques need to be balanced at the contacts.
#include <pairgrasp/grasp.hpp>
#include <pairgrasp/wrenches.hpp>

#include "nnls.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace pairgrasp {

using Vec3 = Eigen::Vector3d;

namespace {

void check_contact_links(const Hand& hand, const Contacts& contacts) {
  if (contacts.links.size() != static_cast<std::size_t>(contacts.points.rows()) ||
      contacts.normals.rows() != contacts.points.rows())
    throw std::invalid_argument("contacts: expected as many normals and links as points, got " +
                                std::to_string(contacts.points.rows()) + " points, " +
                                std::to_string(contacts.normals.rows()) + " normals and " +
                                std::to_string(contacts.links.size()) + " links");
  const int n = static_cast<int>(hand.links().size());
  for (std::size_t c = 0; c < contacts.links.size(); ++c)
    if (contacts.links[c] < 0 || contacts.links[c] >= n)
      throw std::invalid_argument("contacts: link index " + std::to_string(contacts.links[c]) + " of contact " +
                                  std::to_string(c) + " is not one of the hand's " + std::to_string(n) + " links");
  if (!contacts.points.allFinite()) throw std::invalid_argument("points: expected finite coordinates (m)");
}

// How one closing DOF moves the contacts: a finite-difference step of the DOF and each contact's
// displacement (target frame) over it.
struct DofMotion {
  Eigen::Index dof = 0;
  int direction = 0;               // the DOF's closing direction, +1 or -1
  double step = 0.0;               // the step taken (against the closing direction at a limit)
  std::vector<Vec3> displacement;  // per contact
  std::vector<char> moved;         // per contact: beyond round-off (1e-6 of the step)
};

// The motions of the closing DOFs (closing_directions()), in DOF order.
std::vector<DofMotion> closing_motions(const Hand& hand, const Pose& wrist, const Eigen::VectorXd& dofs,
                                       const Contacts& contacts) {
  const Eigen::VectorXi dirs = closing_directions(hand, dofs);  // validates dofs
  check_rigid(wrist, "wrist_pose");
  check_contact_links(hand, contacts);
  const std::vector<Pose> p0 = hand.link_poses(dofs);
  const Eigen::VectorXd lo = hand.dof_lower(), hi = hand.dof_upper();
  const Eigen::Index C = contacts.points.rows();
  const Pose to_wrist = wrist.inverse();
  std::vector<DofMotion> out;
  for (Eigen::Index k = 0; k < dofs.size(); ++k) {
    if (dirs[k] == 0) continue;
    DofMotion m;
    m.dof = k;
    m.direction = dirs[k];
    const double delta = 1e-6 * (hi[k] - lo[k]);
    m.step = dirs[k] * delta;
    if (dofs[k] + m.step > hi[k] || dofs[k] + m.step < lo[k]) m.step = -m.step;  // at a limit: the motion's direction is the same
    Eigen::VectorXd q1 = dofs;
    q1[k] += m.step;
    const std::vector<Pose> p1 = hand.link_poses(q1, true);
    m.displacement.resize(static_cast<std::size_t>(C));
    m.moved.assign(static_cast<std::size_t>(C), 0);
    for (Eigen::Index c = 0; c < C; ++c) {
      const int l = contacts.links[static_cast<std::size_t>(c)];
      const Vec3 x = to_wrist * Vec3(contacts.points.row(c).transpose());
      const Vec3 v = wrist.linear() * (p1[l] * (p0[l].inverse() * x) - x);
      m.displacement[static_cast<std::size_t>(c)] = v;
      m.moved[static_cast<std::size_t>(c)] = v.norm() > 1e-6 * std::abs(m.step);  // else round-off only
    }
    out.push_back(std::move(m));
  }
  return out;
}

}  // namespace

ClosingPush closing_push(const Hand& hand, const Pose& wrist, const Eigen::VectorXd& dofs, const Contacts& contacts) {
  const std::vector<DofMotion> motions = closing_motions(hand, wrist, dofs, contacts);
  const Eigen::Index C = contacts.points.rows();
  double worst = 2.0, least_drive = 2.0;
  for (const DofMotion& m : motions) {
    Vec3 push = Vec3::Zero();
    double weight = 0.0, drive = -1.0;
    for (Eigen::Index c = 0; c < C; ++c) {
      if (!m.moved[static_cast<std::size_t>(c)]) continue;  // a link the DOF does not move
      Vec3 v = m.displacement[static_cast<std::size_t>(c)];
      v *= (m.step * m.direction > 0 ? 1.0 : -1.0) / v.norm();  // unit closing motion
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
      if (!m.moved[static_cast<std::size_t>(c)]) best = std::max(best, -contacts.normals.row(c).dot(back));
    worst = std::min(worst, best);
  }
  ClosingPush out;
  if (worst <= 1.5) out.opposition = worst;
  if (least_drive <= 1.5) out.drive = least_drive;
  return out;
}

double closing_friction(const Hand& hand, const Pose& wrist, const Eigen::VectorXd& dofs, const Contacts& contacts,
                        const Eigen::Vector3d& center, const ClosingFrictionOptions& options) {
  if (!(std::isfinite(options.mu_max) && options.mu_max > 0.0))
    throw std::invalid_argument("mu_max: expected a finite number > 0, got " + std::to_string(options.mu_max));
  if (!(std::isfinite(options.tolerance) && options.tolerance > 0.0))
    throw std::invalid_argument("tolerance: expected a finite number > 0, got " + std::to_string(options.tolerance));
  if (options.edges < 3) throw std::invalid_argument("edges: expected at least 3, got " + std::to_string(options.edges));
  if (!center.allFinite()) throw std::invalid_argument("center: expected finite coordinates (m)");
  const Eigen::Index C = contacts.points.rows();
  std::vector<DofMotion> motions = closing_motions(hand, wrist, dofs, contacts);  // validates the rest
  motions.erase(std::remove_if(motions.begin(), motions.end(),
                               [](const DofMotion& m) {
                                 return std::none_of(m.moved.begin(), m.moved.end(), [](char c) { return c != 0; });
                               }),
                motions.end());
  if (C == 0 || motions.empty()) return std::numeric_limits<double>::quiet_NaN();

  // Each DOF's stall torque: |ratio| * effort of its first joint, relative to the largest.
  std::map<std::string, double> effort;
  for (const HandJoint& j : hand.joints()) effort[j.name] = j.effort;
  Eigen::VectorXd torque(static_cast<Eigen::Index>(motions.size()));
  for (std::size_t k = 0; k < motions.size(); ++k) {
    const DofJoint& first = hand.dofs()[static_cast<std::size_t>(motions[k].dof)].joints.front();
    torque[static_cast<Eigen::Index>(k)] = std::abs(first.ratio) * effort[first.joint];
  }
  if (!(torque.minCoeff() > 0.0)) torque.setOnes();  // an effort missing: equal ones
  torque /= torque.maxCoeff();

  double radius = 0.0;
  for (Eigen::Index c = 0; c < C; ++c)
    radius = std::max(radius, (Vec3(contacts.points.row(c).transpose()) - center).norm());
  radius = std::max(radius, 1e-9);
  // Each moved contact's velocity per unit closing of each DOF (m per rad or m per m), over radius.
  std::vector<std::vector<Vec3>> velocity(motions.size(), std::vector<Vec3>(static_cast<std::size_t>(C), Vec3::Zero()));
  for (std::size_t k = 0; k < motions.size(); ++k)
    for (std::size_t c = 0; c < static_cast<std::size_t>(C); ++c)
      if (motions[k].moved[c])
        velocity[k][c] = motions[k].displacement[c] / (motions[k].step * motions[k].direction * radius);
  const int E = options.edges;
  const Eigen::Index rows = 6 + static_cast<Eigen::Index>(motions.size());
  Eigen::VectorXd b = Eigen::VectorXd::Zero(rows);
  b.tail(static_cast<Eigen::Index>(motions.size())) = torque;
  // Whether forces in the pyramids of coefficient mu balance the stall torques and one another: the
  // columns are the pyramid edges' wrenches (no net force or torque) and the work per unit closing
  // of each DOF along them.
  auto balanced = [&](double mu) {
    const Wrenches w = wrench_matrix(contacts.points, contacts.normals, center, radius, mu, E);  // validates normals
    Eigen::MatrixXd A(rows, w.rows());
    A.topRows(6) = w.transpose();
    for (std::size_t k = 0; k < motions.size(); ++k)
      for (Eigen::Index col = 0; col < w.rows(); ++col)
        A(6 + static_cast<Eigen::Index>(k), col) =
            velocity[k][static_cast<std::size_t>(col / E)].dot(w.row(col).head<3>().transpose());
    return (A * detail::nonnegative_least_squares(A, b) - b).norm() <= 1e-7 * b.norm();
  };
  if (!balanced(options.mu_max)) return std::numeric_limits<double>::infinity();
  if (balanced(0.0)) return 0.0;
  double low = 0.0, high = options.mu_max;
  while (high - low > options.tolerance) {
    const double mid = 0.5 * (low + high);
    (balanced(mid) ? high : low) = mid;
  }
  return high;
}

}  // namespace pairgrasp
