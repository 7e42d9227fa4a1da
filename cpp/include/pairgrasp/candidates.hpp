#pragma once
/// @file candidates.hpp
/// The candidate pipeline: aligned wrist poses in, ranked grasps out. Each chunk of candidates is
/// one call that runs, per candidate and on the library's one thread pool (dynamic scheduling):
///
/// 1. **settle**: a candidate that does not penetrate (depth within the tolerance, no occluded face,
///    no obstacle) is kept as aligned. Otherwise it is adjusted with the least change: the wrist
///    backs off along the hand's approach axis until the links no closing DOF moves (the Barrett
///    palm and knuckles) are clear, at most PipelineOptions::backoff (exponential search, then
///    bisection to h/2; a hand pruned at distance d with depth D stays pruned up to d + D − tol, so
///    the search gives up as soon as that reaches the largest back-off; where even the fully open
///    fingers penetrate at the first clear distance, the farthest tried, the candidate is dropped
///    there without the bisection), then each closing DOF whose
///    links still penetrate opens just enough (bisection between its aligned value and its open
///    limit, to a quarter of its step), keeping the aligned finger shape elsewhere. Only the links a
///    change moves are checked again. A candidate that does not clear is dropped.
/// 2. **deduplicate**: settled candidates that land on the same pose (within h, ~3 degrees and half
///    a DOF step) are evaluated once, the one of the best alignment quality; PipelineOptions::
///    max_evaluations bounds the evaluations over all chunks.
/// 3. **evaluate**: close onto contact, check, find the contacts on free faces, reduce them per link
///    and compute epsilon (evaluate_grasp()), the hull only for candidates that can reach the best
///    (PipelineOptions::hull_rank).
///
/// finish() then ranks the evaluated candidates (unpruned, force closure, epsilon, alignment
/// quality, votes), fine-tunes the best (fine_tune() with seed + rank), drops near-duplicates,
/// scores the grasps that may be returned again with every contact and ranks them by
/// FinishOptions::rank (load resistance by default; robust_quality() of robust.hpp with the robust
/// ranking).
///
/// Results do not depend on the thread count: candidates are independent, and everything that
/// combines them runs in input order. Lengths are metres, angles radians.
#include <pairgrasp/collision.hpp>
#include <pairgrasp/evaluation.hpp>
#include <pairgrasp/robust.hpp>
#include <pairgrasp/types.hpp>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace pairgrasp {

/// Options of CandidatePipeline.
struct PipelineOptions {
  double edge = 0.005;    ///< unit-facet edge h (m): back-off resolution h/2, fine-tune translation h/2, deduplication
  double backoff = 0.05;  ///< largest back-off along the approach axis (m)
  Eigen::VectorXd steps;  ///< per-DOF sampling step (empty: the hand's dof_step())
  /// Scoring of candidates (close is always on; contacts_per_link 0: every contact).
  EvaluateOptions evaluate;
  int max_evaluations = -1;  ///< candidates evaluated at most over all chunks (< 0: no bound)
  /// Bound first: only candidates that can reach the `hull_rank` best epsilons pay for the hull
  /// of their (reduced) contacts. A chunk's candidates are closed and bounded first (the hull-free
  /// bound), then take their hulls best bound first, in rounds of hull_rank, 2 hull_rank, 4 ...
  /// candidates; T is the hull_rank-th best epsilon of the candidates before the round (this
  /// chunk's and earlier ones'). A candidate whose epsilon provably lies below T (QualityOptions::min_epsilon: the
  /// hull-free bounds, then the facets of the active set's hulls) cannot reach them: it is
  /// force-closure with a lower bound of its epsilon when Wolfe's simplex or a subset's hull holds
  /// the origin, else growing subsets decide. So the hull_rank best candidates and the force-closure ones are those of
  /// scoring every candidate fully; the others' epsilon may be a lower bound. 0: every candidate
  /// fully.
  int hull_rank = 0;
  int threads = 0;           ///< threads of the pool used (0: every core)
};

/// An aligned candidate.
struct Candidate {
  int sample_index = 0;             ///< index of the DOF sample it came from (the caller's order)
  Pose pose = Pose::Identity();     ///< aligned wrist pose (target frame)
  Eigen::VectorXd dofs;             ///< the DOF sample's values
  double alignment_quality = 0.0;   ///< Q_A of its alignment (AlignedPose::quality, paper eq. 8)
  int votes = 0;                    ///< rotation votes of the alignment
};

/// How a candidate settled.
enum class Settled {
  Dropped,   ///< still pruned after backing off and opening the fingers
  Aligned,   ///< kept as aligned
  Adjusted,  ///< backed off and/or fingers opened
};

/// "dropped", "aligned" or "adjusted".
const char* to_string(Settled settled);

/// An evaluated candidate.
struct EvaluatedCandidate {
  Candidate candidate;
  Settled settled = Settled::Dropped;
  Pose start_pose = Pose::Identity();  ///< the settled wrist pose
  Eigen::VectorXd start_dofs;          ///< the settled DOF values (before closing)
  double backoff = 0.0;                ///< distance backed off along the approach axis (m)
  GraspEvaluation evaluation;          ///< closed, checked and scored at the settled pose
  double seconds = 0.0;                ///< time from the pipeline's creation until the evaluation finished
};

/// Whether `a` ranks before `b` in finish()'s order of candidates: unpruned, then force closure,
/// then epsilon, then alignment quality, then votes.
bool ranks_before(const EvaluatedCandidate& a, const EvaluatedCandidate& b);

/// What one call of CandidatePipeline::process() did.
struct ChunkReport {
  int settled = 0;          ///< candidates that settled (aligned or adjusted)
  int settled_aligned = 0;  ///< of which kept as aligned
  int evaluated = 0;        ///< candidates evaluated (settled, not duplicates, within max_evaluations)
  int checks = 0;           ///< link-set checks made while settling
  double settle_seconds = 0.0, evaluate_seconds = 0.0;
};

/// A returned grasp.
struct RankedGrasp {
  int candidate = 0;             ///< index into CandidatePipeline::evaluated()
  GraspEvaluation evaluation;    ///< the grasp (the fine-tuned one when fine_tuned)
  bool fine_tuned = false;       ///< a fine-tuning trial strictly better than the candidate
  /// Quality from every contact (the evaluation's may come from reduced contacts).
  GraspQuality quality;
  /// load_resistance() of every contact (quality.hpp): the least pure force at the centre of mass
  /// along the six load directions, per unit total normal force; 0 when not force-closure.
  double load_resistance = 0.0;
  /// closing_push() of every contact (grasp.hpp): how squarely each closing DOF pushes into the
  /// surface and is pushed back; -1 each without contacts.
  ClosingPush push;
  /// Force closure and epsilon under perturbations (Ranking::Robust only).
  std::optional<RobustQuality> robust;
};

/// How finish() orders the grasps.
enum class Ranking {
  /// By robust_quality(): probability of force closure, then the robust epsilon, then force
  /// closure and epsilon as the search scored them (reduced contacts), then as Epsilon.
  Robust,
  /// The paper's: force closure, then epsilon from every contact, then alignment quality, then votes.
  Epsilon,
  /// Rank 1: of the max(top, rank_pool) best distinct grasps by epsilon, the force-closure grasp
  /// with the most distinct hand links in contact (then epsilon as the search scored it). Ranks 2
  /// to top: the next best of them by the search's epsilon, ordered as Epsilon. In the physics
  /// check (docs/physics.md) its rank-1 grasp held more often than the other rankings'.
  Enclosure,
  /// Rank 1: of the same pool, the force-closure grasp with the largest load_resistance() from every
  /// contact (then epsilon as the search scored it): the grasp that resists worst-placed gravity
  /// best, taken among those whose fingers close into the surface and are pushed back
  /// (FinishOptions::min_opposition, min_drive) when there are any. Ranks 2 to top as Enclosure.
  Load,
};

/// Every ranking, in the order of their names.
inline constexpr Ranking kRankings[] = {Ranking::Enclosure, Ranking::Epsilon, Ranking::Load, Ranking::Robust};

/// "enclosure", "epsilon", "load" or "robust".
const char* to_string(Ranking ranking);
/// The Ranking of that name; std::invalid_argument ("rank: ...") otherwise.
Ranking ranking_from_string(const std::string& name);

/// Options of CandidatePipeline::finish().
struct FinishOptions {
  int top = 10;                 ///< grasps returned at most
  int fine_tune = 5;            ///< best distinct candidates fine-tuned
  int fine_tune_iterations = 20;
  std::uint64_t seed = 0;       ///< the grasp of rank k (0-based) is fine-tuned with seed + k
  double angle = 0.05235987755982989;  ///< largest fine-tuning rotation (rad), 3 degrees
  /// No fine-tuning trial starts after this time point (an anytime plan); unset: no limit.
  std::optional<std::chrono::steady_clock::time_point> deadline;
  /// How the returned grasps are ordered. Load by default: in the physics check (docs/physics.md)
  /// its rank-1 grasp held more often than the enclosure, epsilon and robust rankings', and its
  /// top 5 at least as often as the epsilon ranking's.
  Ranking rank = Ranking::Load;
  /// Every ranking but Ranking::Epsilon (robust, enclosure, load): the max(top, rank_pool) best
  /// distinct grasps by epsilon are the pool the ranking picks from. Robust: they are scored by
  /// robust_quality() (with RobustOptions::samples, translation_sigma, rotation_sigma,
  /// friction_spread and quantile from `robust`; the pipeline's scoring and threads; the seed
  /// seed + 0x9E3779B97F4A7C15 (candidate + 1)) and the `top` most robust returned. The pool does
  /// not shrink with `top`, so the first grasps (Enclosure: rank 1) do not depend on how many are
  /// asked for.
  RobustOptions robust;
  int rank_pool = 10;  ///< >= 1 (see above)
  /// Ranking::Load: rank 1 is taken among the pool's force-closure grasps whose closing push
  /// (closing_push() of grasp.hpp) has opposition and drive at least these, when there are any
  /// (-1: every grasp). Chosen on the held-out benchmark's dev half (docs/physics.md).
  double min_opposition = 0.5;
  double min_drive = 0.5;
};

/// The PipelineOptions::hull_rank under which every candidate finish() can pick (fine-tunes, or
/// scores robustly) has its exact epsilon: max(top, rank_pool unless ranking by epsilon,
/// fine_tune).
int hull_rank_for(const FinishOptions& options);

/// Seconds spent in the parts of finish().
struct FinishTimings {
  double fine_tune = 0.0;  ///< ranking, fine-tuning, deduplication and the scoring with every contact
  double robust = 0.0;     ///< robust_quality() of the grasps that may be returned
};

/// Settles, deduplicates and evaluates candidates chunk by chunk, then ranks and fine-tunes. It
/// serves one caller at a time: process() or finish() called while another thread's call runs
/// throws BusyError (each call uses the library's threads itself).
class CandidatePipeline {
 public:
  /// Throws std::invalid_argument for bad options (naming them).
  CandidatePipeline(const GraspChecker& checker, const PipelineOptions& options);

  /// Runs one chunk (see the file comment). The candidates evaluated are appended to evaluated()
  /// in the order they were deduplicated (best alignment quality first, ties in input order).
  /// Throws std::invalid_argument for a candidate with a bad pose or DOF vector ("candidates[k]: ...").
  ChunkReport process(const std::vector<Candidate>& candidates);

  /// Every candidate evaluated so far, in evaluation order.
  const std::vector<EvaluatedCandidate>& evaluated() const { return evaluated_; }

  /// Ranks the evaluated candidates, fine-tunes the best, drops near-duplicates and returns at most
  /// `top` grasps, best first (FinishOptions::rank). `timings`, when given, receives the seconds
  /// of its parts.
  std::vector<RankedGrasp> finish(const FinishOptions& options, FinishTimings* timings = nullptr) const;

  const PipelineOptions& options() const { return options_; }
  /// Links that no closing DOF moves (Hand::links() order): the palm group that backing off clears.
  const std::vector<char>& fixed_links() const { return fixed_; }
  /// Per DOF, the links (Hand::links() order) whose pose it changes: what opening it moves.
  const std::vector<std::vector<char>>& dof_links() const { return moved_; }

 private:
  GraspQuality score_reduced(const Contacts& contacts, double threshold) const;
  void score_robust(std::vector<RankedGrasp>& grasps, const FinishOptions& options) const;

  const GraspChecker& checker_;
  PipelineOptions options_;
  TorqueReference reference_;
  Eigen::Vector3d approach_;
  std::vector<char> fixed_;                 // per link
  std::vector<std::vector<char>> moved_;    // per DOF, per link
  std::set<std::vector<std::int64_t>> seen_;  // deduplication keys
  std::vector<EvaluatedCandidate> evaluated_;
  std::chrono::steady_clock::time_point created_;
  mutable std::atomic<bool> busy_{false};
};

}  // namespace pairgrasp
