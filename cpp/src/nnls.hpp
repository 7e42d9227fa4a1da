#pragma once
// Non-negative least squares. Internal to cpp/src.
#include <Eigen/Core>

namespace pairgrasp::detail {

/// The x >= 0 that minimises |A x - b| (Lawson and Hanson's active-set method, each step a QR
/// solve on the active columns). A column that round-off makes leave at once is not tried again
/// until something else changes, so the method cannot cycle on it.
Eigen::VectorXd nonnegative_least_squares(const Eigen::MatrixXd& A, const Eigen::VectorXd& b);

}  // namespace pairgrasp::detail
