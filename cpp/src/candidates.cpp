// The candidate pipeline: settle, deduplicate, evaluate per chunk; rank and fine-tune at the end.
#include <pairgrasp/candidates.hpp>

#include "busy_guard.hpp"
#include "thread_pool.hpp"

#include <algorithm>
#include <functional>
#include <iterator>
#include <limits>
#include <cmath>
#include <numeric>
#include <queue>
#include <stdexcept>
#include <string>
#include <tuple>

namespace pairgrasp {

const char* to_string(Settled settled) {
  switch (settled) {
    case Settled::Dropped: return "dropped";
    case Settled::Aligned: return "aligned";
    case Settled::Adjusted: return "adjusted";
  }
  return "unknown";
}

const char* to_string(Ranking ranking) {
  switch (ranking) {
    case Ranking::Robust: return "robust";
    case Ranking::Epsilon: return "epsilon";
    case Ranking::Enclosure: return "enclosure";
    case Ranking::Load: return "load";
  }
  return "unknown";
}

Ranking ranking_from_string(const std::string& name) {
  std::string names;  // 'a', 'b' or 'c'
  const std::size_t n = std::size(kRankings);
  for (std::size_t i = 0; i < n; ++i) {
    if (name == to_string(kRankings[i])) return kRankings[i];
    names += (i == 0 ? "'" : (i + 1 == n ? " or '" : ", '")) + std::string(to_string(kRankings[i])) + "'";
  }
  throw std::invalid_argument("rank: expected " + names + ", got '" + name + "'");
}

namespace {

using Clock = std::chrono::steady_clock;

// Above this many wrenches (after quality.hpp's reduction 1) epsilon comes from the active set of
// contacts (reduction 2), which gives the same epsilon: in 6-D a hull of 100-200 wrenches has
// 7,000-18,000 facets and costs 20-70 ms, the active set's smaller hulls about half of that. The
// search (contacts reduced per link) switches at 64, the scoring of the returned grasps (every
// contact) at 128; the volume is then that of the active set's hull, a lower bound.
constexpr int kSearchHullWrenches = 64;
constexpr int kFinalHullWrenches = 128;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

void check_length(const char* name, double v, bool positive) {
  if (!std::isfinite(v) || v < 0.0 || (positive && v == 0.0))
    throw std::invalid_argument(std::string(name) + ": expected a finite length " + (positive ? "> 0" : ">= 0") +
                                " (m), got " + std::to_string(v));
}

// One candidate's settling: the link states at the poses tried, re-checking only the links a
// change moved.
class Settler {
 public:
  Settler(const GraspChecker& checker, const PipelineOptions& o, const Eigen::Vector3d& approach,
          const std::vector<char>& fixed, const std::vector<std::vector<char>>& moved)
      : checker_(checker), hand_(checker.hand()), check_(checker.options()), o_(o), approach_(approach),
        fixed_(fixed), moved_(moved), rest_(fixed.size()), states_(hand_.links().size()) {
    for (std::size_t l = 0; l < rest_.size(); ++l) rest_[l] = !fixed_[l];
  }

  int checks = 0;

  // Settles `c` into `out` (settled, start_pose, start_dofs, backoff).
  void run(const Candidate& aligned, EvaluatedCandidate& out) {
    out.start_pose = aligned.pose;
    out.start_dofs = aligned.dofs;
    out.settled = Settled::Dropped;
    // On a support plane the hand is first lifted along its normal out of it (the least move that
    // clears it, which for a grasp from above is a stand-off along the approach and for one from
    // the side keeps the palm facing the side); a hand that would have to rise more than the
    // largest back-off is dropped before any collision check.
    Candidate c = aligned;
    bool moved = false;
    if (check_.support) {
      // Clear by the contact gap: a link touching an obstacle is pruned.
      const double lift = depth_below(*check_.support, c.pose, c.dofs) + check_.contact_gap;
      if (lift > o_.backoff) return;
      if (lift > 0.0) {
        c.pose.translation() += lift * check_.support->normal.normalized();
        out.start_pose = c.pose;
        moved = true;
      }
    }
    const std::vector<char> all(states_.size(), 1);
    // The palm group first: when it is bad the wrist backs off, and the fingers are only checked
    // where it stops.
    measure(c.pose, c.dofs, fixed_);
    if (any_bad(fixed_)) {
      // 1. Back off until the palm group is clear.
      if (!back_off(c, deepest(fixed_), out)) return;
      moved = true;
    }
    measure(out.start_pose, c.dofs, rest_);
    if (!any_bad(all)) {
      out.settled = moved ? Settled::Adjusted : Settled::Aligned;
      return;
    }
    // 2. Open each closing DOF whose links are still bad, just enough.
    open_fingers(c, out);
  }

 private:
  void measure(const Pose& wrist, const Eigen::VectorXd& q, const std::vector<char>& which) {
    const std::vector<Pose> poses = hand_.link_poses(q, true);
    for (std::size_t l = 0; l < states_.size(); ++l)
      if (which[l]) states_[l] = checker_.link_status(static_cast<int>(l), wrist * poses[l]);
    ++checks;
  }
  bool any_bad(const std::vector<char>& which) const {
    for (std::size_t l = 0; l < states_.size(); ++l)
      if (which[l] && states_[l].pruned) return true;
    return false;
  }
  double deepest(const std::vector<char>& which) const {
    double d = 0.0;
    for (std::size_t l = 0; l < states_.size(); ++l)
      if (which[l]) d = std::max(d, states_[l].depth);
    return d;
  }
  Pose backed(const Pose& pose, double distance) const {
    Pose out = pose;
    out.translation() -= distance * (pose.linear() * approach_);
    return out;
  }

  // How far (m) the hand's lowest link vertex at `wrist`, `q` lies below the plane (<= 0: above it).
  double depth_below(const SupportPlane& plane, const Pose& wrist, const Eigen::VectorXd& q) const {
    const Eigen::Vector3d n = plane.normal.normalized();
    const std::vector<Pose> poses = hand_.link_poses(q, true);
    double lowest = std::numeric_limits<double>::infinity();
    for (std::size_t l = 0; l < hand_.links().size(); ++l) {
      const Mesh& m = hand_.links()[l].mesh;
      const Pose T = wrist * poses[l];
      // Heights of the vertices: n . (R v + t - p) = (R^T n) . v + n . (t - p).
      const Eigen::Vector3d a = T.linear().transpose() * n;
      const double b = n.dot(T.translation() - plane.point);
      if (m.vertices.rows() > 0) lowest = std::min(lowest, (m.vertices * a).minCoeff() + b);
    }
    return std::isfinite(lowest) ? -lowest : 0.0;
  }

  // Exponential search along the approach axis (each pruned distance at least doubles, or grows
  // by the reported depth), then bisection down to h/2 between the last pruned and the first clear
  // distance. While backing off the hand moves rigidly, and a point's penetration depth shrinks by
  // at most the distance it moves, so a palm pruned at d with depth D stays pruned up to
  // d + D - tolerance: the search gives up at once when that reaches the largest back-off.
  bool back_off(const Candidate& c, double depth0, EvaluatedCandidate& out) {
    const double h = o_.edge, most = o_.backoff, tol = check_.depth_tolerance;
    double lo = 0.0, d = std::min(std::max(depth0, h / 2.0) + h / 4.0, most);
    std::optional<double> hi;
    for (;;) {
      measure(backed(c.pose, d), c.dofs, fixed_);
      if (any_bad(fixed_)) {
        lo = d;
        if (!hi) {
          const double dep = deepest(fixed_);
          if (d >= most - 1e-12 || d + dep - tol >= most) return false;
          d = std::min(std::max(2.0 * d, d + dep + h / 4.0), most);
          continue;
        }
      } else {
        // The first clear distance is the farthest the palm goes back: where even the fully open
        // fingers penetrate there, the candidate is dropped without bisecting the back-off (the
        // bisection only brings the hand closer to the target).
        if (!hi && fingers_stuck(backed(c.pose, d), c)) return false;
        hi = d;
      }
      if (*hi - lo <= h / 2.0) {
        out.backoff = *hi;
        out.start_pose = backed(c.pose, *hi);
        if (*hi != d) measure(out.start_pose, c.dofs, fixed_);  // the states of the pose kept
        return true;
      }
      d = (lo + *hi) / 2.0;
    }
  }

  // The closing DOFs whose links are bad in the current states, and the DOF vector with each of
  // them at its open limit (`open`); `moving` marks the links those DOFs move. False when no
  // closing DOF can open.
  bool bad_dofs(const Candidate& c, std::vector<char>& bad_dof, std::vector<char>& moving, Eigen::VectorXd& open) const {
    const Eigen::Index D = c.dofs.size();
    const Eigen::VectorXi dirs = closing_directions(hand_, c.dofs);
    const Eigen::VectorXd lower = hand_.dof_lower(), upper = hand_.dof_upper();
    bad_dof.assign(D, 0);
    moving.assign(states_.size(), 0);
    open = c.dofs;
    bool any = false;
    for (Eigen::Index d = 0; d < D; ++d) {
      const double limit = dirs[d] > 0 ? lower[d] : (dirs[d] < 0 ? upper[d] : c.dofs[d]);
      bool bad = false;
      for (std::size_t l = 0; l < states_.size(); ++l) bad = bad || (moved_[d][l] && states_[l].pruned);
      if (!bad || limit == c.dofs[d]) continue;
      bad_dof[d] = 1;
      open[d] = limit;
      any = true;
      for (std::size_t l = 0; l < states_.size(); ++l) moving[l] = moving[l] || moved_[d][l];
    }
    return any;
  }

  // Whether, at `wrist` (palm group clear), some link is still bad with every bad closing DOF
  // fully open. Leaves the states of the links it measured.
  bool fingers_stuck(const Pose& wrist, const Candidate& c) {
    std::vector<char> bad_dof, moving;
    measure(wrist, c.dofs, rest_);
    if (!any_bad(rest_)) return false;
    Eigen::VectorXd open;
    if (!bad_dofs(c, bad_dof, moving, open)) return true;
    measure(wrist, open, moving);
    return any_bad(rest_);
  }

  // Bisection of every bad closing DOF between its aligned value and its open limit, to a quarter
  // of its step, all at once (a DOF's links decide its own interval).
  void open_fingers(const Candidate& c, EvaluatedCandidate& out) {
    const Eigen::Index D = c.dofs.size();
    std::vector<char> bad_dof, moving;
    Eigen::VectorXd lo = out.start_dofs, hi;
    if (!bad_dofs(c, bad_dof, moving, hi) || any_bad(fixed_)) return;
    measure(out.start_pose, hi, moving);
    if (any_bad(std::vector<char>(states_.size(), 1))) return;  // even fully open, something is bad
    const Eigen::VectorXd steps = hand_.dof_step();  // the hand's resolution, whatever the schedule's step
    for (;;) {
      Eigen::VectorXd mid = hi;
      for (Eigen::Index d = 0; d < D; ++d)
        if (bad_dof[d]) mid[d] = (lo[d] + hi[d]) / 2.0;
      measure(out.start_pose, mid, moving);
      bool done = true;
      for (Eigen::Index d = 0; d < D; ++d) {
        if (!bad_dof[d]) continue;
        bool bad = false;
        for (std::size_t l = 0; l < states_.size(); ++l) bad = bad || (moved_[d][l] && states_[l].pruned);
        (bad ? lo[d] : hi[d]) = mid[d];
        done = done && std::abs(hi[d] - lo[d]) <= std::max(steps[d], 1e-9) / 4.0;
      }
      if (done) break;
    }
    out.start_dofs = hi;
    out.settled = Settled::Adjusted;
  }

  const GraspChecker& checker_;
  const Hand& hand_;
  const CheckOptions& check_;
  const PipelineOptions& o_;
  const Eigen::Vector3d& approach_;
  const std::vector<char>& fixed_;
  const std::vector<std::vector<char>>& moved_;
  std::vector<char> rest_;  // the links some closing DOF moves (not fixed_)
  std::vector<LinkStatus> states_;
};

// Settled candidates that land on the same pose (within h, ~3 degrees, half a DOF step) share a key.
std::vector<std::int64_t> dedupe_key(const Pose& T, const Eigen::VectorXd& q, double h, const Eigen::VectorXd& steps) {
  std::vector<std::int64_t> key;
  auto cell = [&](double v, double size) { key.push_back(static_cast<std::int64_t>(std::floor(v / size + 0.5))); };
  for (int a = 0; a < 3; ++a) cell(T.translation()[a], h);
  for (int col = 0; col < 2; ++col)
    for (int a = 0; a < 3; ++a) cell(T.linear()(a, col), 0.05);
  for (Eigen::Index d = 0; d < q.size(); ++d) cell(q[d], steps[d] > 0 ? steps[d] / 2.0 : 1.0);
  return key;
}

auto rank_key(const GraspEvaluation& e, const Candidate& c) {
  return std::make_tuple(!e.pruned, e.quality.force_closure, e.quality.epsilon, c.alignment_quality, c.votes);
}

}  // namespace

bool ranks_before(const EvaluatedCandidate& a, const EvaluatedCandidate& b) {
  return rank_key(a.evaluation, a.candidate) > rank_key(b.evaluation, b.candidate);
}

CandidatePipeline::CandidatePipeline(const GraspChecker& checker, const PipelineOptions& options)
    : checker_(checker), options_(options), created_(Clock::now()) {
  const Hand& hand = checker.hand();
  check_length("edge", options_.edge, true);
  check_length("backoff", options_.backoff, false);
  if (options_.steps.size() == 0) options_.steps = hand.dof_step();
  if (options_.steps.size() != hand.dof_lower().size())
    throw std::invalid_argument("steps: expected " + std::to_string(hand.dof_lower().size()) + " values, got " +
                                std::to_string(options_.steps.size()));
  if (!options_.steps.allFinite() || (options_.steps.array() < 0.0).any())
    throw std::invalid_argument("steps: expected finite values >= 0");
  if (options_.evaluate.contacts_per_link < 0)
    throw std::invalid_argument("contacts_per_link: expected an integer >= 0, got " +
                                std::to_string(options_.evaluate.contacts_per_link));
  options_.evaluate.close = true;
  // The search ranks by epsilon: the hull volume (several times the cost of the hull in 6-D) is
  // left to the returned grasps, which finish() scores again with every contact.
  if (options_.evaluate.contacts_per_link > 0) {
    options_.evaluate.quality.volume = false;
    options_.evaluate.quality.joggle = true;
    options_.evaluate.quality.max_hull_wrenches =
        std::min(options_.evaluate.quality.max_hull_wrenches, kSearchHullWrenches);
  }
  reference_ = options_.evaluate.reference ? *options_.evaluate.reference : torque_reference(checker.target());
  options_.evaluate.reference = reference_;
  grasp_quality(Points(0, 3), Points(0, 3), reference_.center, reference_.radius, options_.evaluate.quality);
  approach_ = hand.approach();

  // Links each DOF moves, and the links no closing DOF moves (at mid-range).
  const std::vector<std::vector<int>>& dof_links = checker.dof_links();
  const std::size_t L = hand.links().size();
  const Eigen::VectorXd mid = (hand.dof_lower() + hand.dof_upper()) / 2.0;
  const Eigen::VectorXi dirs = closing_directions(hand, mid);
  moved_.assign(dof_links.size(), std::vector<char>(L, 0));
  fixed_.assign(L, 1);
  for (std::size_t d = 0; d < dof_links.size(); ++d)
    for (int l : dof_links[d]) {
      moved_[d][l] = 1;
      if (dirs[static_cast<Eigen::Index>(d)] != 0) fixed_[l] = 0;
    }
}

ChunkReport CandidatePipeline::process(const std::vector<Candidate>& candidates) {
  const detail::BusyGuard busy(busy_, "CandidatePipeline");
  ChunkReport report;
  for (std::size_t k = 0; k < candidates.size(); ++k) {
    const std::string where = "candidates[" + std::to_string(k) + "]";
    try {
      check_rigid(candidates[k].pose, "pose");
      checker_.hand().link_poses(candidates[k].dofs);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(where + ": " + e.what());
    }
  }
  // 1. Settle every candidate.
  auto t0 = Clock::now();
  std::vector<EvaluatedCandidate> settled(candidates.size());
  std::vector<int> checks(candidates.size(), 0);
  detail::parallel_for(candidates.size(), options_.threads, [&](std::size_t k) {
    Settler s(checker_, options_, approach_, fixed_, moved_);
    settled[k].candidate = candidates[k];
    s.run(candidates[k], settled[k]);
    checks[k] = s.checks;
  });
  report.checks = std::accumulate(checks.begin(), checks.end(), 0);
  std::vector<std::size_t> order;
  for (std::size_t k = 0; k < settled.size(); ++k)
    if (settled[k].settled != Settled::Dropped) {
      order.push_back(k);
      ++report.settled;
      if (settled[k].settled == Settled::Aligned) ++report.settled_aligned;
    }
  // 2. Deduplicate, best alignment quality first.
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return settled[a].candidate.alignment_quality > settled[b].candidate.alignment_quality;
  });
  std::vector<std::size_t> todo;
  for (std::size_t k : order)
    if (seen_.insert(dedupe_key(settled[k].start_pose, settled[k].start_dofs, options_.edge, options_.steps)).second)
      todo.push_back(k);
  if (options_.max_evaluations >= 0) {
    const long room = std::max<long>(0, options_.max_evaluations - static_cast<long>(evaluated_.size()));
    if (static_cast<long>(todo.size()) > room) todo.resize(static_cast<std::size_t>(room));
  }
  report.settle_seconds = seconds_since(t0);
  // 3. Evaluate: close, contacts and the hull-free bound of every candidate; then the hulls, best
  // bound first, in rounds whose sizes do not depend on the threads, each round with the threshold
  // T (the hull_rank-th best epsilon so far) the rounds before it raised.
  t0 = Clock::now();
  const int per_link = options_.evaluate.contacts_per_link;
  const bool ranked = options_.hull_rank > 0 && per_link > 1;
  EvaluateOptions first = options_.evaluate;
  first.score = !ranked;
  detail::parallel_for(todo.size(), options_.threads, [&](std::size_t i) {
    EvaluatedCandidate& c = settled[todo[i]];
    c.evaluation = evaluate_grasp(checker_, c.start_pose, c.start_dofs, first);
    c.seconds = seconds_since(created_);
  });
  if (ranked) {
    std::vector<double> eps;  // the epsilons known so far (exact, or lower bounds)
    for (const EvaluatedCandidate& c : evaluated_) eps.push_back(c.evaluation.quality.epsilon);
    std::vector<std::size_t> pending;
    for (std::size_t k : todo) {
      const GraspQuality& q = settled[k].evaluation.quality;
      if (settled[k].evaluation.pruned) {
        eps.push_back(q.epsilon);
      } else {
        pending.push_back(k);
      }
    }
    std::stable_sort(pending.begin(), pending.end(), [&](std::size_t a, std::size_t b) {
      return settled[a].evaluation.quality.epsilon_bound > settled[b].evaluation.quality.epsilon_bound;
    });
    const auto K = static_cast<std::size_t>(options_.hull_rank);
    std::size_t next = 0, round = K;
    while (next < pending.size()) {
      double threshold = 0.0;
      if (eps.size() >= K) {
        std::nth_element(eps.begin(), eps.begin() + static_cast<std::ptrdiff_t>(K - 1), eps.end(), std::greater<double>());
        threshold = eps[K - 1];
      }
      const std::size_t end = std::min(pending.size(), next + round);
      detail::parallel_for(end - next, options_.threads, [&](std::size_t i) {
        EvaluatedCandidate& c = settled[pending[next + i]];
        c.evaluation.quality = score_reduced(c.evaluation.contacts, threshold);
        c.seconds = seconds_since(created_);
      });
      for (std::size_t i = next; i < end; ++i) eps.push_back(settled[pending[i]].evaluation.quality.epsilon);
      next = end;
      round *= 2;
    }
  }
  for (std::size_t k : todo) evaluated_.push_back(std::move(settled[k]));
  report.evaluated = static_cast<int>(todo.size());
  report.evaluate_seconds = seconds_since(t0);
  return report;
}

int hull_rank_for(const FinishOptions& options) {
  return std::max({options.top, options.rank != Ranking::Epsilon ? options.rank_pool : 0, options.fine_tune});
}

GraspQuality CandidatePipeline::score_reduced(const Contacts& k, double threshold) const {
  QualityOptions qo = options_.evaluate.quality;
  qo.open_volume = false;
  qo.min_epsilon = threshold;
  const auto [pts, nrm] = reduced_contacts(k, options_.evaluate.contacts_per_link);
  return grasp_quality(pts, nrm, reference_.center, reference_.radius, qo);
}

std::vector<RankedGrasp> CandidatePipeline::finish(const FinishOptions& options, FinishTimings* timings) const {
  const detail::BusyGuard busy(busy_, "CandidatePipeline");
  const auto t_start = Clock::now();
  if (options.rank_pool < 1)
    throw std::invalid_argument("rank_pool: expected an integer >= 1, got " + std::to_string(options.rank_pool));
  if (options.top < 1) throw std::invalid_argument("top: expected an integer >= 1, got " + std::to_string(options.top));
  if (options.fine_tune < 0 || options.fine_tune_iterations < 0)
    throw std::invalid_argument("fine_tune: expected counts >= 0");
  std::vector<int> kept;
  for (std::size_t k = 0; k < evaluated_.size(); ++k)
    if (!evaluated_[k].evaluation.pruned) kept.push_back(static_cast<int>(k));
  auto key = [&](int k) { return rank_key(evaluated_[k].evaluation, evaluated_[k].candidate); };
  std::stable_sort(kept.begin(), kept.end(), [&](int a, int b) { return key(a) > key(b); });

  // Fine-tune the best, seed + rank.
  std::vector<RankedGrasp> tuned;
  const int n_tune = std::min<int>(options.fine_tune, static_cast<int>(kept.size()));
  for (int k = 0; k < n_tune; ++k) {
    if (options.deadline && Clock::now() >= *options.deadline) break;
    const EvaluatedCandidate& c = evaluated_[kept[k]];
    FineTuneOptions fo;
    fo.steps = options_.steps;
    fo.translation = options_.edge / 2.0;
    fo.angle = options.angle;
    fo.iterations = options.fine_tune_iterations;
    fo.seed = options.seed + static_cast<std::uint64_t>(k);
    fo.evaluate = options_.evaluate;
    fo.threads = options_.threads;
    // The search's evaluation of the start is reused where its epsilon is exact (the same closing
    // and scoring as fine_tune's own).
    FineTuneResult ft = c.evaluation.quality.epsilon_computed ? fine_tune(checker_, c.evaluation, fo)
                                                              : fine_tune(checker_, c.start_pose, c.start_dofs, fo);
    RankedGrasp g;
    g.candidate = kept[k];
    g.evaluation = ft.best ? std::move(*ft.best) : c.evaluation;
    g.fine_tuned = ft.improved;
    tuned.push_back(std::move(g));
  }
  for (std::size_t k = tuned.size(); k < kept.size(); ++k) {
    RankedGrasp g;
    g.candidate = kept[k];
    g.evaluation = evaluated_[kept[k]].evaluation;
    tuned.push_back(std::move(g));
  }
  auto tuned_key = [&](const RankedGrasp& g) {
    const Candidate& c = evaluated_[g.candidate].candidate;
    return std::make_tuple(g.evaluation.quality.force_closure, g.evaluation.quality.epsilon, c.alignment_quality, c.votes);
  };
  std::stable_sort(tuned.begin(), tuned.end(),
                   [&](const RankedGrasp& a, const RankedGrasp& b) { return tuned_key(a) > tuned_key(b); });

  // Near-duplicates (the same key as process(): wrist position within h, rotation, DOFs within half
  // a step) are returned once. The robust and enclosure rankings order a pool that does not shrink
  // with `top`. The walk takes the best remaining grasp by its exact epsilon: a force-closure
  // candidate the search left with a lower bound (beyond hull_rank) enters with its upper bound
  // and is scored exactly when it comes first, so the pool is the exhaustive search's whatever
  // hull_rank was.
  const bool robust = options.rank == Ranking::Robust, load = options.rank == Ranking::Load;
  const bool enclosure = options.rank == Ranking::Enclosure || load;
  const bool pooled = options.rank != Ranking::Epsilon;
  const int pool = pooled ? std::max(options.top, options.rank_pool) : options.top;
  auto exact = [](const RankedGrasp& g) {
    const GraspQuality& q = g.evaluation.quality;
    return !q.force_closure || q.epsilon_computed;
  };
  auto walk_key = [&](std::size_t i) {
    const RankedGrasp& g = tuned[i];
    const Candidate& c = evaluated_[g.candidate].candidate;
    const GraspQuality& q = g.evaluation.quality;
    return std::make_tuple(q.force_closure, exact(g) ? q.epsilon : std::max(q.epsilon, q.epsilon_bound), c.alignment_quality,
                           c.votes, -static_cast<long>(i));
  };
  auto after = [&](std::size_t a, std::size_t b) { return walk_key(a) < walk_key(b); };
  std::priority_queue<std::size_t, std::vector<std::size_t>, decltype(after)> queue(after);
  for (std::size_t i = 0; i < tuned.size(); ++i) queue.push(i);
  std::vector<RankedGrasp> chosen;
  std::set<std::vector<std::int64_t>> signatures;
  while (!queue.empty() && static_cast<int>(chosen.size()) < pool) {
    const std::size_t i = queue.top();
    queue.pop();
    RankedGrasp& g = tuned[i];
    if (!exact(g)) {
      g.evaluation.quality = score_reduced(g.evaluation.contacts, 0.0);
      queue.push(i);
      continue;
    }
    if (!signatures.insert(dedupe_key(g.evaluation.wrist, g.evaluation.dofs, options_.edge, options_.steps)).second)
      continue;
    chosen.push_back(std::move(g));
  }

  // The returned grasps are scored again with every contact, their epsilon exact (the whole hull,
  // or above kFinalHullWrenches the active set). The robust ranking orders its pool by its own
  // measures and the enclosure ranking picks its rank 1 from the search's scores, so that only
  // the `top` they return need the scoring; the epsilon ranking orders by the scoring's epsilon.
  QualityOptions full = options_.evaluate.quality;
  full.open_volume = true;
  full.volume = true;
  full.joggle = false;
  full.max_hull_wrenches = std::min(QualityOptions().max_hull_wrenches, kFinalHullWrenches);
  auto rescore = [&](std::vector<RankedGrasp>& grasps) {
    detail::parallel_for(grasps.size(), options_.threads, [&](std::size_t i) {
      const GraspEvaluation& e = grasps[i].evaluation;
      grasps[i].quality = options_.evaluate.contacts_per_link > 0 && e.contacts.points.rows() > 0
                              ? grasp_quality(e.contacts.points, e.contacts.normals, reference_.center,
                                              reference_.radius, full)
                              : e.quality;
    });
  };
  double robust_seconds = 0.0;
  auto order_key = [&](const RankedGrasp& g, long i) {  // the robust and the epsilon rankings
    const Candidate& c = evaluated_[g.candidate].candidate;
    const RobustQuality none;
    const RobustQuality& r = g.robust ? *g.robust : none;
    const GraspQuality& q = robust ? g.evaluation.quality : g.quality;
    return std::make_tuple(r.force_closure_probability, r.epsilon, q.force_closure, q.epsilon, c.alignment_quality, c.votes, -i);
  };
  auto load_resistances = [&](std::vector<RankedGrasp>& grasps) {
    detail::parallel_for(grasps.size(), options_.threads, [&](std::size_t i) {
      const Contacts& k = grasps[i].evaluation.contacts;
      grasps[i].load_resistance =
          k.points.rows() > 0 ? load_resistance(k.points, k.normals, reference_.center, reference_.radius,
                                                options_.evaluate.quality.contact)
                              : 0.0;
    });
  };
  auto pushes = [&](std::vector<RankedGrasp>& grasps) {
    detail::parallel_for(grasps.size(), options_.threads, [&](std::size_t i) {
      const GraspEvaluation& e = grasps[i].evaluation;
      grasps[i].push = e.contacts.points.rows() > 0 ? closing_push(checker_.hand(), e.wrist, e.dofs, e.contacts)
                                                    : ClosingPush();
    });
  };
  std::vector<RankedGrasp> out;
  if (enclosure) {
    // Rank 1: the pool's force-closure grasp with the most distinct hand links in contact (Load: the
    // largest load resistance), then the search's epsilon. The rest: the pool's next best by the
    // search's epsilon, scored with every contact and ordered as the epsilon ranking orders them.
    if (load) {
      load_resistances(chosen);
      pushes(chosen);
    }
    auto lead_key = [&](std::size_t i) {
      const GraspQuality& q = chosen[i].evaluation.quality;
      const std::vector<int>& links = chosen[i].evaluation.contacts.links;
      const double measure = load ? chosen[i].load_resistance
                                  : static_cast<double>(std::set<int>(links.begin(), links.end()).size());
      const ClosingPush& push = chosen[i].push;
      const bool opposed = !load || (push.opposition >= options.min_opposition && push.drive >= options.min_drive);
      return std::make_tuple(q.force_closure, opposed, measure, q.epsilon, -static_cast<long>(i));
    };
    std::size_t lead = 0;
    for (std::size_t i = 1; i < chosen.size(); ++i)
      if (lead_key(i) > lead_key(lead)) lead = i;
    if (!chosen.empty()) out.push_back(std::move(chosen[lead]));
    for (std::size_t i = 0; i < chosen.size() && static_cast<int>(out.size()) < options.top; ++i)
      if (i != lead) out.push_back(std::move(chosen[i]));
    rescore(out);
    if (out.size() > 2)
      std::stable_sort(out.begin() + 1, out.end(), [&](const RankedGrasp& x, const RankedGrasp& y) {
        return order_key(x, 0) > order_key(y, 0);
      });
  } else {
    if (robust) {
      const auto t_robust = Clock::now();
      score_robust(chosen, options);
      robust_seconds = seconds_since(t_robust);
    } else {
      rescore(chosen);
    }
    std::vector<std::size_t> order(chosen.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
      return order_key(chosen[x], static_cast<long>(x)) > order_key(chosen[y], static_cast<long>(y));
    });
    for (std::size_t i : order) {
      if (static_cast<int>(out.size()) >= options.top) break;
      out.push_back(std::move(chosen[i]));
    }
    if (robust) rescore(out);
  }
  if (!load) {  // the load ranking measured its pool, which the returned grasps come from
    load_resistances(out);
    pushes(out);
  }
  if (timings) {
    timings->robust = robust_seconds;
    timings->fine_tune = seconds_since(t_start) - robust_seconds;
  }
  return out;
}

void CandidatePipeline::score_robust(std::vector<RankedGrasp>& grasps, const FinishOptions& options) const {
  RobustOptions ro = options.robust;
  ro.evaluate = options_.evaluate;
  ro.threads = options_.threads;
  for (RankedGrasp& g : grasps) {
    ro.seed = options.seed + 0x9E3779B97F4A7C15ULL * static_cast<std::uint64_t>(g.candidate + 1);
    g.robust = robust_quality(checker_, g.evaluation.wrist, g.evaluation.start_dofs, ro);
  }
}

}  // namespace pairgrasp
