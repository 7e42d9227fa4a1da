#pragma once
/// @file evaluation.hpp
/// Scoring one grasp and improving it by local search: close the fingers onto contact, check
/// penetration and pruning, find the contacts on free faces and compute their Ferrari-Canny
/// epsilon (quality.hpp); fine_tune() searches around a grasp for a better one.
///
/// Frames: the wrist pose maps wrist coordinates to target coordinates (p_T = R·p_G + t). Lengths
/// are metres, angles radians, DOF values radians (metres for linear DOFs).
#include <pairgrasp/collision.hpp>
#include <pairgrasp/grasp.hpp>
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/quality.hpp>
#include <pairgrasp/types.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace pairgrasp {

/// The torque reference of epsilon for a target.
struct TorqueReference {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();  ///< torque origin: the centre of mass (m)
  double radius = 0.0;  ///< torque scale: the largest distance of a vertex from `center` (m)
};

/// The default torque reference of `mesh`: its centre of mass and its largest vertex distance from
/// it. Throws std::invalid_argument ("target: ...") when they cannot be derived (no vertex,
/// non-finite centre, all vertices at the centre).
TorqueReference torque_reference(const Mesh& mesh);

/// Indices (sorted) of at most `per_link` contacts per link (`links[k]` is contact k's link),
/// spread by farthest-point sampling: per link, the first kept contact is the one farthest from the
/// link's contact centroid, each next the farthest from those kept (ties: the lowest index). The
/// hull of the kept contacts' wrenches lies inside the hull of all of them, so epsilon computed
/// from them is a lower bound of the full epsilon and force closure is never claimed wrongly.
/// Throws std::invalid_argument for `per_link` < 1 or a `links` size other than the points'.
std::vector<int> reduce_contacts(const Points& points, const std::vector<int>& links, int per_link);

/// The contact points and target normals reduce_contacts() keeps of `contacts`, in its order:
/// (K,3) each. Throws as reduce_contacts().
std::pair<Points, Points> reduced_contacts(const Contacts& contacts, int per_link);

/// Options of evaluate_grasp().
struct EvaluateOptions {
  /// Close the closing DOFs onto contact first (close_fingers()); else evaluate the DOFs given.
  bool close = true;
  /// Friction model (QualityOptions::contact) and hull options of epsilon.
  QualityOptions quality;
  /// Torque reference of epsilon; unset: torque_reference() of the checker's target.
  std::optional<TorqueReference> reference;
  /// Score at most this many contacts per link (reduce_contacts(): a lower bound of epsilon, an
  /// order of magnitude faster on patches of ~100 contacts, and no hull volume for a grasp that is
  /// not force-closure); 0: every contact. The evaluation still lists every contact.
  int contacts_per_link = 0;
  /// false: close, check and find the contacts only; the quality then holds n_contacts and the
  /// hull-free epsilon_bound of the (reduced) contacts, epsilon_computed false, force_closure false.
  bool score = true;
};

/// A grasp closed onto contact, checked and scored.
struct GraspEvaluation {
  Pose wrist = Pose::Identity();  ///< wrist pose (target frame)
  Eigen::VectorXd dofs;           ///< DOF values evaluated (the closed values when closed)
  Eigen::VectorXd start_dofs;     ///< DOF values before closing
  /// Pruned: penetration beyond the tolerance, an obstacle collision, or a link touching occluded
  /// faces. A pruned grasp is not scored (epsilon 0, not force-closure).
  bool pruned = false;
  double depth = 0.0;         ///< largest penetration depth over links, target and obstacles (m)
  double target_depth = 0.0;  ///< largest penetration depth into the target (m)
  std::string reason;         ///< why it is pruned ("" when kept)
  Contacts contacts;          ///< every contact on free faces (find_contacts())
  /// Epsilon, volume and force closure of the contacts (reduced per EvaluateOptions); when pruned,
  /// zero with reason "pruned: <reason>".
  GraspQuality quality;
  std::vector<StopReason> closing;  ///< why each DOF stopped closing (empty when not closed)
  CheckResult check;                ///< the check at (wrist, dofs)
};

/// Closes (unless options.close is false), checks and scores one grasp. Throws
/// std::invalid_argument for a wrist pose that is not a finite rigid transform ("wrist_pose: ..."),
/// a bad DOF vector ("dofs: ..."), bad quality options or a negative contacts_per_link.
GraspEvaluation evaluate_grasp(const GraspChecker& checker, const Pose& wrist, const Eigen::VectorXd& dofs,
                               const EvaluateOptions& options = {});

/// Whether `a` is a strictly better grasp than `b`: unpruned first, then force-closure, then the
/// higher epsilon, then the larger hull volume.
bool better_grasp(const GraspEvaluation& a, const GraspEvaluation& b);

/// Options of fine_tune().
struct FineTuneOptions {
  /// Per-DOF step (empty: the hand's dof_step()); each DOF moves within half of it (0: fixed).
  Eigen::VectorXd steps;
  double translation = 0.0025;  ///< largest translation of a trial (m), e.g. half a unit facet
  double angle = 0.05235987755982989;  ///< largest rotation of a trial (rad), default 3 degrees
  int iterations = 30;          ///< trials (>= 0)
  std::uint64_t seed = 0;       ///< seed of the trials (see fine_tune())
  EvaluateOptions evaluate;     ///< scoring of the start and of every trial (always closed)
  int threads = 1;              ///< trials evaluated at once (0: every core); results do not depend on it
};

/// Result of fine_tune().
struct FineTuneResult {
  /// The best grasp found (never pruned); empty when the start is pruned and no trial is unpruned.
  std::optional<GraspEvaluation> best;
  GraspEvaluation start;  ///< the starting grasp, closed and scored
  int trials = 0;         ///< trials evaluated
  int kept = 0;           ///< trials that were not pruned
  int improvements = 0;   ///< trials that replaced the best grasp so far
  bool improved = false;  ///< the best grasp is a trial strictly better than the start
  std::string reason;     ///< "" when `best` is set, else why nothing is returned
};

/// Local random search around a grasp for a better epsilon. The start is closed and scored; each
/// trial then perturbs the *starting* grasp (the search stays in its neighbourhood) by
/// - a translation uniform in the ball of radius options.translation,
/// - a rotation by an angle uniform in [-angle, angle] about a uniformly random axis through the
///   pivot, the centroid of the start's contacts (the wrist origin when it has none), so that the
///   fingers move by about the translation and not by the lever of the palm,
/// - DOF values uniform within steps/2 of the starting DOFs, clamped to the limits,
/// closes again and re-scores; the best grasp (better_grasp(), strictly, so ties keep the earlier)
/// is kept. The trials are drawn from a 64-bit Mersenne Twister (std::mt19937_64, whose sequence
/// the C++ standard fixes) seeded with `seed`, in trial order and before any is evaluated, so the
/// result is the same on every platform and for any thread count.
/// Throws std::invalid_argument as evaluate_grasp() and for bad options ("steps: ...",
/// "translation: ...", "angle: ...", "iterations: ...").
FineTuneResult fine_tune(const GraspChecker& checker, const Pose& wrist, const Eigen::VectorXd& dofs,
                         const FineTuneOptions& options = {});

/// fine_tune() from a start already closed and scored: `start` must be what evaluate_grasp()
/// returns for (start.wrist, start.start_dofs) with options.evaluate and `close` set (a search's
/// evaluation of the candidate, reused instead of computed again). Its epsilon must be exact
/// (GraspQuality::epsilon_computed); std::invalid_argument otherwise.
FineTuneResult fine_tune(const GraspChecker& checker, const GraspEvaluation& start,
                         const FineTuneOptions& options = {});

}  // namespace pairgrasp
