#pragma once
// Internal: the six-pairing solver without argument checks and without building PairPoseResult
// (no rotation matrices, axes or angles), for the Aligner's inner loop. solve_pair_pose() checks
// its arguments, calls this and dresses its output, so both give the same versors bit for bit.
#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>

namespace pairgrasp::detail {

/// One ranked solver candidate: the versor (w >= 0), satisfied pairings s (agreement
/// s(s-1)/2), rms residual (radians) and point order.
struct VersorCandidate {
  Eigen::Quaterniond q;
  int s = 0;
  int order = 0;
  double rms = 0.0;
};

constexpr int kMaxVersorCandidates = 32;

/// Solver settings derived once from PairPoseOptions (see solve_pair_pose()).
struct VersorSettings {
  double sin_collinear = 0.0;  // sin(min(collinear_tolerance, pi/2))
  int min_s = 2;               // satisfied pairings a candidate needs (2 or 3)
  double chord = 0.0;          // 2 sin(tol/2)
  double cos_half_tol = 1.0;   // cos(tol/2)
};

/// Settings for an angle tolerance, collinear tolerance and min_agreement (1..3), unchecked.
VersorSettings versor_settings(double angle_tolerance, double collinear_tolerance, int min_agreement);

/// Status as PairPoseStatus: 0 ok, 1 underdetermined, 2 no agreement. Candidates best first
/// (written to out[0..n)), n returned in `count`. Arguments as solve_pair_pose(), unchecked.
/// `orders` (bit 0: order 0, bit 1: order 1) skips the point orders the caller has proven to give
/// no candidate (the Aligner's pre-filter); the result is then the same as with both.
int solve_versors(const Eigen::Vector3d& gp0, const Eigen::Vector3d& gp1, const Eigen::Vector3d& gn0,
                  const Eigen::Vector3d& gn1, const Eigen::Vector3d& tp0, const Eigen::Vector3d& tp1,
                  const Eigen::Vector3d& tn0, const Eigen::Vector3d& tn1, const VersorSettings& settings,
                  std::array<VersorCandidate, kMaxVersorCandidates>& out, int& count, unsigned orders = 3);

}  // namespace pairgrasp::detail
