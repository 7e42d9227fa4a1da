#include <pairgrasp/features.hpp>

#include "surface_feature.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace pairgrasp {

Eigen::Vector3d pair_feature(const Eigen::Vector3d& p_i, const Eigen::Vector3d& n_i,
                             const Eigen::Vector3d& p_j, const Eigen::Vector3d& n_j) {
  const Eigen::Vector3d* in[4] = {&p_i, &n_i, &p_j, &n_j};
  const char* names[4] = {"p_i", "n_i", "p_j", "n_j"};
  for (int k = 0; k < 4; ++k)
    if (!in[k]->allFinite()) throw std::invalid_argument(std::string(names[k]) + ": expected finite values");
  for (int k : {1, 3})
    if (!(std::abs(in[k]->norm() - 1.0) <= 1e-6))
      throw std::invalid_argument(std::string(names[k]) + ": expected a unit normal, got length " +
                                  std::to_string(in[k]->norm()));
  Eigen::Vector3d e;
  detail::pair_feature_raw(p_i.data(), n_i.data(), p_j.data(), n_j.data(), e.data());
  return e;
}

}  // namespace pairgrasp
