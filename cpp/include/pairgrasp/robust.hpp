#pragma once
/// @file robust.hpp
/// Robust grasp quality: how a grasp's force closure and epsilon hold up when the hand is not
/// exactly where it was planned and friction is not exactly what was assumed. The grasp is closed
/// and scored again (evaluate_grasp()) at sampled perturbations of its wrist pose and friction
/// coefficient; the probability of force closure and a low quantile of epsilon over the samples
/// measure its robustness (the probability of force closure under uncertainty is Dex-Net's grasp
/// metric; re-ranking Barrett grasps by pose robustness is Weisz and Allen, ICRA 2012).
///
/// Lengths are metres, angles radians.
#include <pairgrasp/collision.hpp>
#include <pairgrasp/evaluation.hpp>
#include <pairgrasp/types.hpp>

#include <cstdint>
#include <vector>

namespace pairgrasp {

/// Options of robust_quality(): the perturbation model and the statistics.
///
/// A perturbed hand whose start pose (the grasp's DOFs before closing) penetrates the target stops
/// where it first touches on its way in: it backs off along its approach axis in 0.5 mm steps, at
/// most 3 mm; a sample still pruned after closing (penetration, occluded faces, obstacles) counts
/// as a failure (not force-closure, epsilon 0). The target does not move while the fingers close
/// (as in close_fingers()): fingers coupled through one DOF (a parallel jaw) that reach the target
/// at different times leave the later ones short of it, which real closing would make up by pushing
/// the object, so for such hands the measures are pessimistic about offsets along the closing.
struct RobustOptions {
  int samples = 8;                        ///< perturbed evaluations (>= 1)
  double translation_sigma = 0.001;       ///< wrist offset, normal per axis of the target frame (m)
  double rotation_sigma = 0.017453292519943295;  ///< wrist rotation about a random axis through the wrist origin, normal (rad); 1 degree
  /// Friction coefficient uniform in [mu (1 - r), mu (1 + r)], mu the scoring's (EvaluateOptions::
  /// quality.contact.mu): 0.2 gives U(0.4, 0.6) at mu 0.5.
  double friction_spread = 0.2;
  /// The robust epsilon is this quantile of the samples' epsilons (the k-th smallest, k =
  /// floor(quantile (n - 1)), over the n samples).
  double quantile = 0.25;
  std::uint64_t seed = 0;   ///< seed of the perturbations (std::mt19937_64)
  EvaluateOptions evaluate; ///< scoring of every sample (always closed from the grasp's DOFs before closing)
  int threads = 1;          ///< samples evaluated at once (0: every core); results do not depend on it
};

/// What robust_quality() returns.
struct RobustQuality {
  double force_closure_probability = 0.0;  ///< fraction of the samples that are force-closure
  double epsilon = 0.0;       ///< RobustOptions::quantile of the samples' epsilons
  double mean_epsilon = 0.0;  ///< mean epsilon of the samples
  int samples = 0;            ///< samples evaluated
  int backed_off = 0;         ///< samples whose start pose penetrated and backed off
  int pruned = 0;             ///< samples pruned after closing (failures)
  std::vector<double> epsilons;  ///< per sample (0 when pruned), in sample order
};

/// The perturbed wrist poses of robust_quality(), in sample order: each is `wrist` turned by an
/// angle N(0, rotation_sigma) about a uniformly random axis through the wrist origin and moved by
/// N(0, translation_sigma) per axis, both in the target frame (p_T = R·p_G + t: R' = R_δ R, t' = t +
/// δ). Drawn from std::mt19937_64(seed) with a fixed algorithm, so the same on every platform.
/// `frictions` receives each sample's friction coefficient. Throws std::invalid_argument for bad options.
std::vector<Pose> robust_perturbations(const Pose& wrist, double mu, const RobustOptions& options,
                                       std::vector<double>& frictions);

/// Closes and scores the grasp (`start_dofs`: the DOF values before closing, GraspEvaluation::
/// start_dofs) at each perturbation of robust_perturbations() with its friction coefficient, and
/// returns the statistics. Deterministic for a seed, for any thread count. Throws
/// std::invalid_argument as evaluate_grasp() and for bad options ("samples: ...", ...).
RobustQuality robust_quality(const GraspChecker& checker, const Pose& wrist, const Eigen::VectorXd& start_dofs,
                             const RobustOptions& options = {});

}  // namespace pairgrasp
