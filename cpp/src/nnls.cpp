// Non-negative least squares (Lawson and Hanson's active-set method).
#include "nnls.hpp"

#include <Eigen/QR>

#include <algorithm>
#include <vector>

namespace pairgrasp::detail {

Eigen::VectorXd nonnegative_least_squares(const Eigen::MatrixXd& A, const Eigen::VectorXd& b) {
  const Eigen::Index n = A.cols();
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  std::vector<char> passive(static_cast<std::size_t>(n), 0), blocked(static_cast<std::size_t>(n), 0);
  const double tiny = 1e-13 * std::max(1.0, A.cwiseAbs().maxCoeff()) * std::max(1.0, b.norm());
  std::vector<Eigen::Index> cols;
  for (Eigen::Index outer = 0; outer < 3 * n + 10; ++outer) {
    const Eigen::VectorXd w = A.transpose() * (b - A * x);
    Eigen::Index t = -1;
    double best = tiny;
    for (Eigen::Index i = 0; i < n; ++i)
      if (!passive[static_cast<std::size_t>(i)] && !blocked[static_cast<std::size_t>(i)] && w[i] > best) best = w[i], t = i;
    if (t < 0) break;
    passive[static_cast<std::size_t>(t)] = 1;
    for (Eigen::Index inner = 0; inner < n + 10; ++inner) {
      cols.clear();
      for (Eigen::Index i = 0; i < n; ++i)
        if (passive[static_cast<std::size_t>(i)]) cols.push_back(i);
      Eigen::MatrixXd Ap(A.rows(), static_cast<Eigen::Index>(cols.size()));
      for (std::size_t k = 0; k < cols.size(); ++k) Ap.col(static_cast<Eigen::Index>(k)) = A.col(cols[k]);
      const Eigen::VectorXd z = Ap.colPivHouseholderQr().solve(b);
      if ((z.array() > tiny).all()) {
        x.setZero();
        for (std::size_t k = 0; k < cols.size(); ++k) x[cols[k]] = z[static_cast<Eigen::Index>(k)];
        break;
      }
      double alpha = 1.0;
      for (std::size_t k = 0; k < cols.size(); ++k) {
        const double zk = z[static_cast<Eigen::Index>(k)], xk = x[cols[k]];
        if (zk <= tiny) alpha = std::min(alpha, xk / (xk - zk));
      }
      for (std::size_t k = 0; k < cols.size(); ++k) {
        const Eigen::Index i = cols[k];
        x[i] += alpha * (z[static_cast<Eigen::Index>(k)] - x[i]);
        if (x[i] <= tiny) x[i] = 0.0, passive[static_cast<std::size_t>(i)] = 0;
      }
      // Round-off can make the column just added leave at once (a zero step): it is not tried again
      // until something else changes, so the method cannot cycle on it.
      if (!passive[static_cast<std::size_t>(t)] && alpha == 0.0) {
        blocked[static_cast<std::size_t>(t)] = 1;
        break;
      }
    }
    if (passive[static_cast<std::size_t>(t)]) std::fill(blocked.begin(), blocked.end(), 0);
  }
  return x;
}

}  // namespace pairgrasp::detail
