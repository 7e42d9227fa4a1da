#pragma once
/// @file search.hpp
/// One plan's search over a GraspPlanner: DOF samples in, ranked grasps out. A GraspSearch holds the
/// candidate pipeline (candidates.hpp), the samples aligned so far, the aligned poses kept for
/// deepening, and the counts and stage times. Its three steps are the whole plan loop:
///
/// - add_samples(): align the samples (all threads), make the best poses_per_sample poses of each
///   a candidate, and settle, deduplicate and evaluate them (one pipeline chunk);
/// - deepen(): the next-ranked kept poses of earlier samples become candidates;
/// - finish(): rank, fine-tune and return the grasps.
///
/// What to add, when to deepen and when to stop is the caller's choice: plan_samples() adds a list
/// of samples a chunk at a time; the Python Planner runs its schedules (coarse-to-fine, early
/// rejection, time limit) over the same object, so both give the same grasps for the same samples.
///
/// A search is used by one thread at a time: a second concurrent call throws BusyError. Lengths are
/// metres, angles radians.
#include <pairgrasp/candidates.hpp>
#include <pairgrasp/planner.hpp>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace pairgrasp {

/// Options of one plan (GraspSearch, plan_samples()); unset optionals are derived as documented.
struct PlanOptions {
  /// Best aligned poses of each sample that become candidates at once (a parallel jaw's: grasp
  /// lines, each with its Aligner::options().antipodal_rolls turns).
  int poses_per_sample = 3;
  /// Aligned poses kept per sample added with keep_deeper, for deepen() (at most this many in all,
  /// the first poses_per_sample included; not more than poses_per_sample: none kept).
  int max_poses_per_sample = 3;
  int chunk = 128;  ///< plan_samples(): samples added (aligned, settled and evaluated) together
  /// Sampling step of angular DOFs (rad) for fine-tuning and deduplication; unset: the hand's.
  std::optional<double> step;
  /// Largest back-off along the approach axis when settling (m); unset: the planner's
  /// (PlannerSetup::backoff, half the hand's reach unless PlannerOptions::backoff).
  std::optional<double> backoff;
  int top = 10;               ///< grasps returned
  int fine_tune = 5;          ///< best distinct grasps fine-tuned
  int fine_tune_iterations = 20;
  std::uint64_t seed = 0;     ///< the grasp of rank k is fine-tuned with seed + k
  double mu = 0.5;            ///< friction coefficient
  int edges = 8;              ///< friction-pyramid edges
  int contacts_per_link = 4;  ///< contacts scored per link while searching (0: every contact)
  std::optional<int> max_evaluations;  ///< candidates evaluated at most (unset: all)
  /// PipelineOptions::hull_rank (unset: hull_rank_for() of the finish options, 0 when every contact
  /// is scored).
  std::optional<int> hull_rank;
  Ranking rank = FinishOptions().rank;  ///< FinishOptions::rank
  int robust_samples = 8;               ///< RobustOptions::samples of the robust ranking
};

/// Throws std::invalid_argument naming the first bad field of `options` ("top: expected an integer >= 1, got 0").
void validate(const PlanOptions& options);

/// What one add_samples() or deepen() call did.
struct SearchStep {
  long samples = 0;          ///< samples aligned
  long aligned_poses = 0;    ///< candidates made (aligned poses, or kept poses deepened)
  long settled = 0;          ///< candidates that settled (aligned or adjusted)
  long settled_aligned = 0;  ///< of which kept as aligned
  long evaluated = 0;        ///< candidates evaluated (settled, not duplicates, within max_evaluations)
  double align_seconds = 0.0, settle_seconds = 0.0, evaluate_seconds = 0.0;
};

/// The search of one plan (see the file comment).
class GraspSearch {
 public:
  /// Throws std::invalid_argument naming a bad option.
  explicit GraspSearch(const GraspPlanner& planner, const PlanOptions& options = {});
  GraspSearch(const GraspSearch&) = delete;
  GraspSearch& operator=(const GraspSearch&) = delete;

  /// Aligns `samples` (DOF vectors within the limits; their indices continue samples()), makes the
  /// best poses_per_sample poses of each a candidate and settles, deduplicates and evaluates them.
  /// With `keep_deeper`, the next poses up to max_poses_per_sample are kept for deepen(). Throws
  /// std::invalid_argument ("samples[k]: ...") for a bad sample, before any work.
  SearchStep add_samples(const std::vector<Eigen::VectorXd>& samples, bool keep_deeper = false);

  /// The rank (0-based, per sample) of the kept poses deepen() takes next; -1 when none is left.
  int deepen_rank() const;
  /// Makes the next at most `max_candidates` kept poses of rank deepen_rank() candidates, in sample
  /// order, and settles and evaluates them.
  SearchStep deepen(std::size_t max_candidates);

  /// Indices of the samples with an evaluated candidate, best first by their best candidate (the
  /// order finish() ranks candidates in: unpruned, force closure, epsilon, Q_A, votes), ties by index.
  std::vector<int> ranked_samples() const;

  /// Ranks the evaluated candidates, fine-tunes the best (no trial starts after `deadline`) and
  /// returns at most `top` grasps, best first (CandidatePipeline::finish()). `timings` receives the
  /// seconds of its parts.
  std::vector<RankedGrasp> finish(std::optional<std::chrono::steady_clock::time_point> deadline = std::nullopt,
                                  FinishTimings* timings = nullptr) const;

  const GraspPlanner& planner() const { return planner_; }
  /// The options, with step and backoff resolved.
  const PlanOptions& options() const { return options_; }
  /// The samples added so far, in order (a candidate's `sample` indexes this).
  const std::vector<Eigen::VectorXd>& samples() const { return samples_; }
  /// Every candidate evaluated so far, in evaluation order.
  const std::vector<EvaluatedCandidate>& evaluated() const { return pipeline_.evaluated(); }
  /// Evaluated candidates that are force-closure.
  long force_closure() const;
  /// Totals so far: samples, aligned_poses, deepened_poses, settled, settled_aligned, evaluated.
  std::map<std::string, long> counts() const;
  /// Seconds so far: align, settle, evaluate.
  std::map<std::string, double> timings() const;

 private:
  SearchStep run(std::vector<Candidate> candidates, SearchStep step);

  GraspPlanner planner_;  // a handle on the shared, immutable planner state
  PlanOptions options_;
  FinishOptions finish_;
  CandidatePipeline pipeline_;
  std::vector<Eigen::VectorXd> samples_;
  std::vector<std::vector<Candidate>> deeper_;  // per rank - poses_per_sample: kept poses, in sample order
  std::size_t deepen_rank_ = 0, deepen_next_ = 0;  // into deeper_
  SearchStep total_;
  long deepened_ = 0;
  mutable std::atomic<bool> busy_{false};
};

/// What plan_samples() returns.
struct PlanReport {
  std::vector<RankedGrasp> grasps;             ///< best first
  std::vector<EvaluatedCandidate> candidates;  ///< every evaluated candidate, in evaluation order
  std::map<std::string, long> counts;          ///< samples, aligned_poses, settled, settled_aligned, evaluated, force_closure
  std::map<std::string, double> timings;       ///< seconds: align, settle, evaluate, fine_tune, robust
};

/// Runs `samples` (DOF vectors within the limits) through a GraspSearch, `options.chunk` samples per
/// add_samples(), then finish(). Deterministic for a seed and independent of the thread count.
/// Throws std::invalid_argument for bad options or samples.
PlanReport plan_samples(const GraspPlanner& planner, const std::vector<Eigen::VectorXd>& samples,
                        const PlanOptions& options = {});

}  // namespace pairgrasp
