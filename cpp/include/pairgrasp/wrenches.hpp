#pragma once
/// @file wrenches.hpp
/// Contact wrenches of point and soft-finger contacts with Coulomb friction (paper eq. 2-5), in
/// GraspIt's friction-pyramid convention. The grasp wrench space built from them, and its
/// Ferrari-Canny epsilon, are in quality.hpp.
#include <pairgrasp/types.hpp>

#include <optional>

namespace pairgrasp {

/// W x 6 wrenches, one per row: [f; (p - c) x f / r].
using Wrenches = Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>;

/// The friction model of every contact of a grasp.
///
/// Point contact (the default): the Coulomb cone of coefficient `mu` is approximated by a pyramid
/// of `edges` edges, edge k being f_k = n + mu (cos(2 pi k/edges) t1 + sin(2 pi k/edges) t2) (unit
/// normal component, not normalised; see contact_frame() for t1, t2).
///
/// Soft-finger contact (`soft`): the contact also resists a moment about its normal,
/// |m_n| <= torsion * f_n. Its force/moment set is the elliptic limit surface
/// (f_t / mu)^2 + (m_n / torsion)^2 <= f_n^2, sampled at latitudes: the equator is the pyramid;
/// the poles are the pure-torsion wrenches [n; ((p - c) x n +- torsion n) / r]; `soft_rings` rings
/// phi_j = j (pi/2) / (soft_rings + 1) on each hemisphere add the edges
/// [n + mu cos(phi_j) t_k; ((p - c) x f +- torsion sin(phi_j) n) / r].
struct ContactModel {
  double mu = 0.5;                ///< Coulomb friction coefficient, >= 0
  int edges = 8;                  ///< pyramid edges R, >= 3
  bool soft = false;              ///< soft-finger contacts (torsional friction about each normal)
  /// Torsional friction radius in metres, >= 0 (for a circular patch of radius a under uniform
  /// pressure it is 2 mu a / 3). Required when `soft`; ignored for point contacts.
  std::optional<double> torsion;
  int soft_rings = 0;             ///< latitude rings per hemisphere, >= 0 (soft contacts only)

  /// Wrenches per contact: `edges` for point contacts, edges * (1 + 2 soft_rings) + 2 for soft ones.
  int wrenches_per_contact() const;
};

/// The contact frame of an OUTWARD target normal `normal` (any non-zero length): rows t1, t2, n,
/// with n = -normal / |normal| the direction the finger pushes, t1 the coordinate axis least
/// aligned with n (lowest index on a tie) projected onto the tangent plane and normalised, and
/// t2 = n x t1, so (t1, t2, n) is right-handed. The basis depends on the normal alone.
/// Throws std::invalid_argument ("normals: ...") for a non-finite or zero-length normal.
Eigen::Matrix3d contact_frame(const Eigen::Vector3d& normal);

/// The wrenches of contacts `points` (N,3, metres) with the target's OUTWARD normals `normals`
/// (N,3, any non-zero length; fingers push along -normal), torque origin `center` (metres, usually
/// the target's centre of mass) and torque scale `radius` (metres, usually the target's largest
/// vertex distance from `center`; it makes the torque part dimensionless).
/// Contact i gives rows i*D .. i*D+D-1 (D = model.wrenches_per_contact()): the pyramid edges
/// k = 0..R-1, then for each ring its edges with the positive and then the negative moment, then
/// the two poles (+torsion, -torsion).
/// Throws std::invalid_argument naming the argument for mismatched sizes, non-finite values, a
/// zero-length normal, radius <= 0, mu < 0, edges < 3, soft_rings < 0, torsion < 0, or a soft
/// model without torsion.
Wrenches wrench_matrix(const Points& points, const Points& normals, const Eigen::Vector3d& center,
                       double radius, const ContactModel& model);

/// Point contacts: wrench_matrix(points, normals, center, radius, ContactModel{mu, edges}).
Wrenches wrench_matrix(const Points& points, const Points& normals, const Eigen::Vector3d& center,
                       double radius, double mu = 0.5, int edges = 8);

}  // namespace pairgrasp
