#include <pairgrasp/error.hpp>
#include <pairgrasp/wrenches.hpp>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace pairgrasp {

namespace {

void check_model(const ContactModel& m) {
  if (!(m.mu >= 0.0) || !std::isfinite(m.mu))
    throw std::invalid_argument("mu: expected a finite value >= 0, got " + std::to_string(m.mu));
  if (m.edges < 3) throw std::invalid_argument("edges: expected >= 3, got " + std::to_string(m.edges));
  if (m.soft_rings < 0)
    throw std::invalid_argument("soft_rings: expected >= 0, got " + std::to_string(m.soft_rings));
  if (m.torsion && (!(*m.torsion >= 0.0) || !std::isfinite(*m.torsion)))
    throw std::invalid_argument("torsion: expected a finite value >= 0, got " + std::to_string(*m.torsion));
  if (m.soft && !m.torsion)
    throw std::invalid_argument("torsion: soft contacts need the torsional friction radius in metres");
}

/// (along t1, along t2, moment about n) of each of a contact's wrench directions, in row order.
std::vector<Eigen::Vector3d> local_directions(const ContactModel& m) {
  const double two_pi = 2.0 * std::acos(-1.0);
  std::vector<Eigen::Vector3d> ring(m.edges);
  for (int k = 0; k < m.edges; ++k) {
    const double theta = two_pi * k / m.edges;
    ring[k] = Eigen::Vector3d(m.mu * std::cos(theta), m.mu * std::sin(theta), 0.0);
  }
  std::vector<Eigen::Vector3d> out(ring);
  if (!m.soft) return out;
  const double g = *m.torsion;
  for (int j = 1; j <= m.soft_rings; ++j) {
    const double phi = 0.25 * two_pi * j / (m.soft_rings + 1);
    for (const double sign : {1.0, -1.0})
      for (const Eigen::Vector3d& r : ring)
        out.emplace_back(std::cos(phi) * r.x(), std::cos(phi) * r.y(), sign * g * std::sin(phi));
  }
  out.emplace_back(0.0, 0.0, g);
  out.emplace_back(0.0, 0.0, -g);
  return out;
}

}  // namespace

int ContactModel::wrenches_per_contact() const { return soft ? edges * (1 + 2 * soft_rings) + 2 : edges; }

Eigen::Matrix3d contact_frame(const Eigen::Vector3d& normal) {
  if (!normal.allFinite()) throw std::invalid_argument("normals: non-finite value");
  const double len = normal.norm();
  if (len < 1e-30) throw std::invalid_argument("normals: zero length");
  const Eigen::Vector3d n_in = -normal / len;
  Eigen::Index axis = 0;
  n_in.cwiseAbs().minCoeff(&axis);  // first minimum: lowest index wins a tie
  const Eigen::Vector3d e = Eigen::Vector3d::Unit(axis);
  const Eigen::Vector3d t1 = (e - e.dot(n_in) * n_in).normalized();  // |.| >= sqrt(2/3)
  Eigen::Matrix3d frame;
  frame.row(0) = t1.transpose();
  frame.row(1) = n_in.cross(t1).transpose();
  frame.row(2) = n_in.transpose();
  return frame;
}

Wrenches wrench_matrix(const Points& points, const Points& normals, const Eigen::Vector3d& center,
                       double radius, const ContactModel& model) {
  detail::check_size("normals: rows (one per contact point)", points.rows(), normals.rows());
  if (!points.allFinite()) throw std::invalid_argument("points: non-finite value");
  if (!normals.allFinite()) throw std::invalid_argument("normals: non-finite value");
  if (!center.allFinite()) throw std::invalid_argument("center: non-finite value");
  if (!(radius > 0.0) || !std::isfinite(radius))
    throw std::invalid_argument("radius: expected a finite value > 0, got " + std::to_string(radius));
  check_model(model);

  const std::vector<Eigen::Vector3d> dirs = local_directions(model);
  const Eigen::Index per = static_cast<Eigen::Index>(dirs.size());
  Wrenches w(points.rows() * per, 6);
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    if (normals.row(i).norm() < 1e-30)
      throw std::invalid_argument("normals: row " + std::to_string(i) + " has zero length");
    const Eigen::Matrix3d frame = contact_frame(normals.row(i).transpose());
    const Eigen::Vector3d t1 = frame.row(0), t2 = frame.row(1), n_in = frame.row(2);
    const Eigen::Vector3d arm = points.row(i).transpose() - center;
    for (Eigen::Index k = 0; k < per; ++k) {
      const Eigen::Vector3d& d = dirs[k];
      const Eigen::Vector3d f = n_in + d.x() * t1 + d.y() * t2;
      w.row(i * per + k).head<3>() = f.transpose();
      w.row(i * per + k).tail<3>() = ((arm.cross(f) + d.z() * n_in) / radius).transpose();
    }
  }
  return w;
}

Wrenches wrench_matrix(const Points& points, const Points& normals, const Eigen::Vector3d& center,
                       double radius, double mu, int edges) {
  ContactModel model;
  model.mu = mu;
  model.edges = edges;
  return wrench_matrix(points, normals, center, radius, model);
}

}  // namespace pairgrasp
