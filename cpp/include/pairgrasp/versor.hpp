#pragma once
/// @file versor.hpp
/// The six-pairing versor solver (paper eq. 15-19): the rigid poses that carry one gripper pair
/// of oriented points onto one target pair, without SVD and without matrix inversion.
///
/// A correspondence (gripper pair G, target pair T) gives three vector pairings A -> B for each
/// of the two point orders:
///
///   order 0 (G0<->T0, G1<->T1): -nG0 -> nT0,  -nG1 -> nT1,  uG -> uT
///   order 1 (G0<->T1, G1<->T0): -nG0 -> nT1,  -nG1 -> nT0,  uG -> -uT
///
/// where u = (p1 - p0) / |p1 - p0| and the gripper normals are flipped (-n): at a contact the
/// target's outward normal is opposite to the finger's. Every rotation carrying A into B has
/// its axis on the great circle perpendicular to A - B; two pairings i, j of one order meet at
/// m = (A_i - B_i) x (A_j - B_j) / |...| (eq. 17) and there each gives a signed angle about m,
/// theta = atan2(m . (A x B), A . B - (m . A)(m . B)) (eq. 18 gives only its cosine). The
/// meeting (m, -m) is one rotation since (theta, m) == (-theta, -m).
///
/// Degenerate cases are handled one by one: a pairing with A = B (axis +-A, angle from another
/// pairing), all pairings with A = B (identity), parallel differences (the other meetings, or a
/// TRIAD frame construction R = F_T F_G^T when every difference is parallel, i.e. the axis lies
/// in the plane of coplanar vectors), phi = 1 (the two normal pairings coincide), coincident
/// points (no difference vector: two pairings only) and the antipodal/collinear case (both
/// normals along the connecting line on one side: the roll about that line is free, the
/// correspondence is underdetermined and gives no candidate).
///
/// Agreement. Each hypothesis rotation R is checked against every pairing of its order: a
/// pairing is satisfied when the angle between R.A and B is at most `angle_tolerance`. With s
/// satisfied pairings, the agreement is s(s-1)/2, the number of the order's three meetings
/// (pairs of pairings) that R reproduces: 3 for an exact correspondence in the right order, 1
/// when only one meeting agrees (the wrong order, generically), at most 1 when the points
/// coincide. Candidates need agreement >= max(1, options.min_agreement).
#include <pairgrasp/types.hpp>

#include <vector>

namespace pairgrasp {

/// Options for solve_pair_pose().
struct PairPoseOptions {
  /// A pairing A -> B is satisfied by R when angle(R.A, B) <= this (radians).
  double angle_tolerance = 0.05;
  /// A side whose two normals and connecting line all lie within this angle (radians) of one
  /// line is collinear: the roll about that line is free, so the correspondence is
  /// underdetermined.
  double collinear_tolerance = 1e-3;
  /// Candidates with less agreement are not returned (1..3; 2 and 3 both mean "all three
  /// pairings", since agreement is 0, 1 or 3).
  int min_agreement = 1;
};

/// Why solve_pair_pose() returned what it returned.
enum class PairPoseStatus {
  Ok,               ///< at least one candidate
  Underdetermined,  ///< one side's normals lie along its connecting line (antipodal pair): roll is free
  NoAgreement,      ///< no rotation satisfies two pairings of either order: not a rigid correspondence
};

/// Name of a status: "ok", "underdetermined", "no_agreement".
const char* to_string(PairPoseStatus status);

/// One rigid pose carrying the gripper pair onto the target pair: p_T = rotation * p_G + translation.
struct PairPoseCandidate {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< gripper (wrist) frame -> target frame
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();   ///< metres, t = P_T - R.P_G of the pair midpoints (eq. 19)
  Eigen::Quaterniond versor = Eigen::Quaterniond::Identity();  ///< the rotation as a unit quaternion, w >= 0
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  ///< canonical axis: upper hemisphere (z > 0, or z = 0 and y > 0, ...)
  double angle = 0.0;   ///< radians in (-pi, pi] about `axis` (sign flipped with the axis; pi, not -pi)
  int agreement = 0;    ///< meetings of its order reproduced: s(s-1)/2 for s satisfied pairings (0..3)
  int order = 0;        ///< 0: G0<->T0, G1<->T1; 1: G0<->T1, G1<->T0
  double residual = 0;  ///< radians: root mean square of angle(R.A, B) over the satisfied pairings

  /// The candidate as an isometry.
  Pose pose() const;
};

/// Candidates, best first (most agreement, then smallest residual, then order 0 before 1).
struct PairPoseResult {
  PairPoseStatus status = PairPoseStatus::NoAgreement;
  std::vector<PairPoseCandidate> candidates;
};

/// Solves the rigid poses of one correspondence.
///
/// Gripper points gp0, gp1 (metres, wrist frame) with normals gn0, gn1 **as stored on the
/// gripper** (unit, pointing out of the finger surface; the solver uses -n); target points tp0,
/// tp1 with unit outward normals tn0, tn1. Throws std::invalid_argument for non-finite values or
/// non-unit normals (|1 - |n|| > 1e-6), naming the argument.
PairPoseResult solve_pair_pose(const Eigen::Vector3d& gp0, const Eigen::Vector3d& gp1,
                               const Eigen::Vector3d& gn0, const Eigen::Vector3d& gn1,
                               const Eigen::Vector3d& tp0, const Eigen::Vector3d& tp1,
                               const Eigen::Vector3d& tn0, const Eigen::Vector3d& tn1,
                               const PairPoseOptions& options = {});

/// Same as above, refilling `result` (its storage is reused: no allocation once warm).
void solve_pair_pose(const Eigen::Vector3d& gp0, const Eigen::Vector3d& gp1,
                     const Eigen::Vector3d& gn0, const Eigen::Vector3d& gn1,
                     const Eigen::Vector3d& tp0, const Eigen::Vector3d& tp1,
                     const Eigen::Vector3d& tn0, const Eigen::Vector3d& tn1,
                     const PairPoseOptions& options, PairPoseResult& result);

/// Array form: gripper_points, gripper_normals, target_points, target_normals are (2,3) each.
/// Throws std::invalid_argument ("gripper_points: expected 2 rows, got 3") for a wrong shape.
PairPoseResult solve_pair_pose(const Points& gripper_points, const Points& gripper_normals,
                               const Points& target_points, const Points& target_normals,
                               const PairPoseOptions& options = {});

/// Rotation matrix of `angle` radians about the unit `axis` (quaternion / Rodrigues form).
Eigen::Matrix3d versor_rotation(double angle, const Eigen::Vector3d& axis);

/// Brings (angle, axis) to the canonical form: axis in the upper hemisphere (flipping the angle
/// with it), angle in (-pi, pi] with (-pi, m) written (pi, m), axis (0,0,1) for angle 0.
/// `axis` must be unit.
void canonicalize_versor(double& angle, Eigen::Vector3d& axis);

/// Angle (radians, in [0, pi]) of the rotation a^T b: the rotation distance between a and b.
double rotation_distance(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b);

}  // namespace pairgrasp
