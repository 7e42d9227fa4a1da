#include <pairgrasp/error.hpp>
#include <pairgrasp/wrenches.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

namespace pairgrasp {

Wrenches wrench_matrix(const Points& points, const Points& normals, const Eigen::Vector3d& center,
                       double radius, double mu, int edges) {
  detail::check_size("normals: rows (one per contact point)", points.rows(), normals.rows());
  if (!points.allFinite()) throw std::invalid_argument("points: non-finite value");
  if (!normals.allFinite()) throw std::invalid_argument("normals: non-finite value");
  if (!center.allFinite()) throw std::invalid_argument("center: non-finite value");
  if (!(radius > 0.0) || !std::isfinite(radius))
    throw std::invalid_argument("radius: expected a finite value > 0, got " + std::to_string(radius));
  if (!(mu >= 0.0) || !std::isfinite(mu))
    throw std::invalid_argument("mu: expected a finite value >= 0, got " + std::to_string(mu));
  if (edges < 3) throw std::invalid_argument("edges: expected >= 3, got " + std::to_string(edges));

  const double two_pi = 2.0 * std::acos(-1.0);
  Wrenches w(points.rows() * edges, 6);
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    const Eigen::Vector3d n = normals.row(i).transpose();
    const double len = n.norm();
    if (len < 1e-30) throw std::invalid_argument("normals: row " + std::to_string(i) + " has zero length");
    const Eigen::Vector3d n_in = -n / len;
    Eigen::Index axis = 0;
    n_in.cwiseAbs().minCoeff(&axis);  // first minimum: lowest index wins a tie
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(axis);
    const Eigen::Vector3d t1 = (e - e.dot(n_in) * n_in).normalized();
    const Eigen::Vector3d t2 = n_in.cross(t1);
    const Eigen::Vector3d arm = (points.row(i).transpose() - center) / radius;
    for (int k = 0; k < edges; ++k) {
      const double theta = two_pi * k / edges;
      const Eigen::Vector3d f = n_in + mu * (std::cos(theta) * t1 + std::sin(theta) * t2);
      w.row(i * edges + k).head<3>() = f.transpose();
      w.row(i * edges + k).tail<3>() = arm.cross(f).transpose();
    }
  }
  return w;
}

}  // namespace pairgrasp
