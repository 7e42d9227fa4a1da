#pragma once
/// @file quality.hpp
/// Grasp quality: the Ferrari-Canny epsilon of the L1 grasp wrench space (paper eq. 2-7) and the
/// wrench hull's volume, computed with qhull's reentrant library (each call has its own qhull
/// state, so calls may run on several threads at once).
///
/// The grasp wrench space is the convex hull of every contact wrench (wrenches.hpp), forces per
/// unit total normal force and torques divided by the torque scale r (dimensionless). The grasp
/// is force-closure when the origin is strictly inside that hull, and epsilon is then the distance
/// from the origin to the nearest hull facet; otherwise epsilon is 0.
///
/// A wrench set that does not span the 6-D wrench space (two antipodal point contacts,
/// frictionless or single-face contacts, fewer than 7 distinct wrenches) cannot be force-closure.
/// It is found from the singular values of the distinct wrenches (rank: singular values above
/// 1e-9 times the largest) before qhull is called and is an ordinary non-closure (epsilon 0 and a
/// reason), not an error. An origin within 1e-9 times the largest wrench norm of a facet counts as
/// on the boundary (not force-closure). A full-rank hull that fails qhull's precision checks is
/// built again from joggled input (qhull's QJ, moves of about 1e-11 of the coordinates).
///
/// Two reductions keep epsilon exact:
/// 1. Contacts sharing a normal bit for bit (several contacts on one flat face) have the same
///    pyramid edges, and a contact's wrenches are affine in its point, so only the vertices of
///    each normal group's point hull are kept (epsilon and volume unchanged).
/// 2. When more than QualityOptions::max_hull_wrenches wrenches remain, epsilon comes from an
///    active set S of wrenches (to start, every wrench of 4 contacts spread by farthest-point
///    sampling over (point / r, normal)). Each facet f of hull(S), unit normal a_f at distance d_f
///    from the origin, bounds the whole set: epsilon <= U = min_f max_w a_f.w and epsilon >= L =
///    min_f d_f = epsilon(S). When U = L epsilon is exact; otherwise the farthest wrench beyond
///    each facet with d_f < U joins S and the hull is rebuilt. U <= 0 proves non-closure. The
///    volume is then that of hull(S), a lower bound (GraspQuality::volume_exact false).
#include <pairgrasp/types.hpp>
#include <pairgrasp/wrenches.hpp>

#include <string>

namespace pairgrasp {

/// Options of grasp_quality().
struct QualityOptions {
  /// Friction model of the contacts (mu, pyramid edges, soft-finger torsion and rings).
  ContactModel contact;
  /// Above this many wrenches (after reduction 1) epsilon comes from the active set and the
  /// volume is a lower bound. >= 7.
  int max_hull_wrenches = 320;
  /// false: the hull volume of a grasp that is not force-closure is not wanted, so a grasp whose
  /// wrenches a hyperplane through the origin separates from it (found by Wolfe's minimum-norm-
  /// point algorithm, no hull and no linear programme, and checked on the plane) is reported
  /// without a hull: volume 0, volume_exact false. Force-closure results are unchanged.
  bool open_volume = true;
  /// false: no hull volume at all (volume 0, volume_exact false), epsilon and force closure
  /// unchanged; the volume (qhull's FA, the facets' areas in 6-D) costs several times the hull
  /// itself, so a search that ranks by epsilon skips it.
  bool volume = true;
  /// true: qhull's joggled input ("QJ") first, the exact options only where it fails: about twice
  /// as fast in 6-D, epsilon within ~1e-9 relative of the exact hull's (a search that ranks
  /// candidates sets it; the grasps it returns are scored again without it). Deterministic.
  bool joggle = false;
  /// A caller that only wants grasps whose epsilon reaches this value (dimensionless, >= 0) skips
  /// the hull of any grasp whose epsilon provably lies below it: first by epsilon_upper_bound(),
  /// then by a descent of the support function from its directions, then, where neither decides
  /// and there are more than max_hull_wrenches wrenches, by the active set of reduction 2, whose
  /// bound U falls as its set grows: it stops once U < min_epsilon. The result then has
  /// epsilon_computed false, volume 0, volume_exact false and the bound that decided in
  /// epsilon_bound. Force closure is still decided exactly, without the full hull where possible:
  /// Wolfe's minimum-norm point either separates the origin (not force-closure, epsilon 0) or ends
  /// on a simplex of 7 wrenches holding it, whose facet distances bound epsilon from below (or an
  /// active set's hull holds it); only where neither certificate holds do hulls of growing subsets
  /// of the contacts decide. A skipped force-closure grasp has that lower bound as its epsilon.
  /// 0: every full-rank grasp gets its hull.
  double min_epsilon = 0.0;
};

/// Result of grasp_quality().
struct GraspQuality {
  /// Distance from the origin to the nearest wrench-hull facet when force-closure, else 0
  /// (dimensionless: forces per unit total normal force, torques divided by the torque scale).
  double epsilon = 0.0;
  /// 6-D volume of the wrench hull (0 when the wrenches do not span 6 dimensions).
  double volume = 0.0;
  bool force_closure = false;  ///< the origin is strictly inside the wrench hull
  int n_contacts = 0;          ///< contacts given
  int n_wrenches = 0;          ///< wrenches of every contact (rows of wrench_matrix())
  int rank = 0;                ///< rank of the wrench set (6 when it spans the wrench space)
  std::string reason;          ///< why the grasp is not force-closure ("" when it is)
  /// `volume` is the hull volume of every wrench; false when epsilon came from the active set
  /// (the volume of a subset's hull, a lower bound) or no hull was built.
  bool volume_exact = true;
  /// The hull-free upper bound of epsilon_upper_bound() (0 when rank < 6), or the tighter bound
  /// that skipped the hull (see QualityOptions::min_epsilon).
  double epsilon_bound = 0.0;
  /// false when the hull of a force-closure grasp was skipped because epsilon_bound <
  /// QualityOptions::min_epsilon (epsilon is then a lower bound).
  bool epsilon_computed = true;
};

/// Ferrari-Canny epsilon (L1) and hull volume of the grasp given by its contacts: `points` (N,3,
/// metres), the target's OUTWARD normals `normals` (N,3, any non-zero length), torque origin
/// `center` and torque scale `radius` (metres), as wrench_matrix(). No contacts: not
/// force-closure ("no contacts").
/// Throws std::invalid_argument naming the argument for malformed input (see wrench_matrix();
/// also max_hull_wrenches < 7 and a negative or non-finite min_epsilon).
GraspQuality grasp_quality(const Points& points, const Points& normals, const Eigen::Vector3d& center,
                           double radius, const QualityOptions& options = {});

/// Force resistance of a grasp: for each unit direction d (the rows of `directions`, (K,3), target
/// frame), the largest t such that the wrench (t d, 0), a pure force at the torque origin `center`,
/// lies in the grasp wrench space of grasp_quality() (the L1 hull of every contact wrench): the
/// largest force along d at that point, per unit total normal force, that the contacts can exert
/// without a torque about it. With the centre of mass as the origin these are the loads of gravity
/// and of the hand's accelerations (the physics check's loads); epsilon asks for every wrench.
/// Each value is at least epsilon (the epsilon-ball lies in the hull) and at most the largest force
/// component of a contact wrench along d. All 0 when the grasp is not force-closure.
///
/// Computed without a hull: from t = max_w w.(d,0), Wolfe's minimum-norm point of the wrenches
/// less (t d, 0) is either 0 within rounding (t is the answer) or gives a supporting plane a of
/// the hull beyond (t d, 0), and t becomes max_w a.w / a.(d,0), which decreases strictly to the
/// answer (it ends after a few steps where the ray leaves the hull through a facet's interior).
/// Relative accuracy about 1e-6. Arguments as grasp_quality() (the contact model's friction,
/// edges and soft contacts); throws std::invalid_argument naming a malformed argument, or a
/// direction that is not a finite unit vector.
Eigen::VectorXd force_resistance(const Points& points, const Points& normals, const Eigen::Vector3d& center,
                                 double radius, const Points& directions, const ContactModel& contact = {});

/// The six load directions of the physics check (docs/physics.md): +x, +y, +z, -x, -y, -z of the
/// target frame, along which gravity is turned while the hand holds the object.
Points load_directions();

/// Load resistance: the least force_resistance() along load_directions(); 0 when not force-closure.
double load_resistance(const Points& points, const Points& normals, const Eigen::Vector3d& center, double radius,
                       const ContactModel& contact = {});

/// An upper bound of the Ferrari-Canny epsilon of the wrench set `wrenches`, without a hull: for
/// any unit direction v a ball of radius epsilon inside the hull stays in {x : v.x <= max_w v.w},
/// so epsilon <= min_v max_w v.w over the 12 directions +-e_k of the axes and the 12 directions
/// +-v_k of the right singular vectors of the wrench matrix. It is never above the smallest
/// singular value (max_w v.w <= |W v|), and a negative minimum proves non-closure; the result is
/// clamped to >= 0. O(W) time. Empty set: 0. Throws std::invalid_argument for non-finite wrenches.
double epsilon_upper_bound(const Wrenches& wrenches);

}  // namespace pairgrasp
