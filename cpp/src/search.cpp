// GraspSearch (one plan's samples -> aligned poses -> candidate pipeline -> grasps) and plan_samples.
#include <pairgrasp/search.hpp>

#include "busy_guard.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

namespace pairgrasp {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

void at_least(const char* name, long v, long low) {
  if (v < low)
    throw std::invalid_argument(std::string(name) + ": expected an integer >= " + std::to_string(low) + ", got " +
                                std::to_string(v));
}

void finite_at_least_zero(const char* name, double v, bool zero_ok) {
  if (!std::isfinite(v) || v < 0.0 || (!zero_ok && v == 0.0))
    throw std::invalid_argument(std::string(name) + ": expected a finite number " + (zero_ok ? ">= 0" : "> 0") +
                                ", got " + std::to_string(v));
}

FinishOptions finish_options(const PlanOptions& o) {
  FinishOptions fo;
  fo.top = o.top;
  fo.fine_tune = o.fine_tune;
  fo.fine_tune_iterations = o.fine_tune_iterations;
  fo.seed = o.seed;
  fo.rank = o.rank;
  fo.robust.samples = o.robust_samples;
  return fo;
}

// The options with step and backoff resolved against the planner.
PlanOptions resolved(const GraspPlanner& planner, PlanOptions o) {
  validate(o);
  // The planner's index leaves out the surface that cannot hold a force-closure grasp at its mu.
  if (o.mu > planner.options().mu)
    throw std::invalid_argument("mu: " + std::to_string(o.mu) + " exceeds the planner's mu of " +
                                std::to_string(planner.options().mu) +
                                " (PlannerOptions::mu, the friction its index was built for); build the planner with it");
  if (!o.backoff) o.backoff = planner.setup().backoff;
  if (!o.hull_rank) o.hull_rank = o.contacts_per_link > 0 ? hull_rank_for(finish_options(o)) : 0;
  return o;
}

PipelineOptions pipeline_options(const GraspPlanner& planner, const PlanOptions& o) {
  PipelineOptions po;
  po.edge = planner.setup().edge;
  po.backoff = *o.backoff;
  po.steps = planner.steps(o.step.value_or(0.0));
  po.evaluate.quality.contact.mu = o.mu;
  po.evaluate.quality.contact.edges = o.edges;
  po.evaluate.reference = planner.reference();
  po.evaluate.contacts_per_link = o.contacts_per_link;
  po.max_evaluations = o.max_evaluations.value_or(-1);
  po.hull_rank = *o.hull_rank;
  po.threads = planner.options().threads;
  return po;
}

}  // namespace

void validate(const PlanOptions& o) {
  at_least("poses_per_sample", o.poses_per_sample, 1);
  at_least("max_poses_per_sample", o.max_poses_per_sample, 1);
  at_least("chunk", o.chunk, 1);
  if (o.step) finite_at_least_zero("step", *o.step, false);
  if (o.backoff) finite_at_least_zero("backoff", *o.backoff, true);
  at_least("top", o.top, 1);
  at_least("fine_tune", o.fine_tune, 0);
  at_least("fine_tune_iterations", o.fine_tune_iterations, 0);
  finite_at_least_zero("mu", o.mu, true);
  at_least("edges", o.edges, 3);
  at_least("contacts_per_link", o.contacts_per_link, 0);
  if (o.max_evaluations) at_least("max_evaluations", *o.max_evaluations, 1);
  if (o.hull_rank) at_least("hull_rank", *o.hull_rank, 0);
  at_least("robust_samples", o.robust_samples, 1);
}

GraspSearch::GraspSearch(const GraspPlanner& planner, const PlanOptions& options)
    : planner_(planner),
      options_(resolved(planner, options)),
      finish_(finish_options(options_)),
      pipeline_(planner.checker(), pipeline_options(planner, options_)) {}

SearchStep GraspSearch::run(std::vector<Candidate> candidates, SearchStep step) {
  step.aligned_poses = static_cast<long>(candidates.size());
  const ChunkReport r = pipeline_.process(candidates);
  step.settled = r.settled;
  step.settled_aligned = r.settled_aligned;
  step.evaluated = r.evaluated;
  step.settle_seconds = r.settle_seconds;
  step.evaluate_seconds = r.evaluate_seconds;
  total_.samples += step.samples;
  total_.aligned_poses += step.aligned_poses;
  total_.settled += step.settled;
  total_.settled_aligned += step.settled_aligned;
  total_.evaluated += step.evaluated;
  total_.align_seconds += step.align_seconds;
  total_.settle_seconds += step.settle_seconds;
  total_.evaluate_seconds += step.evaluate_seconds;
  return step;
}

SearchStep GraspSearch::add_samples(const std::vector<Eigen::VectorXd>& samples, bool keep_deeper) {
  const detail::BusyGuard busy(busy_, "GraspSearch");
  for (std::size_t k = 0; k < samples.size(); ++k) {
    try {
      planner_.hand().link_poses(samples[k]);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("samples[" + std::to_string(k) + "]: " + e.what());
    }
  }
  const auto t0 = Clock::now();
  const int first = options_.poses_per_sample;
  const int most = keep_deeper ? std::max(first, options_.max_poses_per_sample) : first;
  if (deeper_.size() < static_cast<std::size_t>(most - first)) deeper_.resize(static_cast<std::size_t>(most - first));
  const std::size_t turns = planner_.setup().antipodal
                                ? static_cast<std::size_t>(planner_.aligner().options().antipodal_rolls) : 1;
  // Aligned 64 samples per call: a bounded batch of results in memory at once.
  constexpr std::size_t kAlignBatch = 64;
  std::vector<Candidate> cands;
  for (std::size_t a = 0; a < samples.size(); a += kAlignBatch) {
    const std::vector<Eigen::VectorXd> part(samples.begin() + static_cast<long>(a),
                                            samples.begin() + static_cast<long>(std::min(samples.size(), a + kAlignBatch)));
    const std::vector<AlignResult> aligned = planner_.align(part, most);
    for (std::size_t i = 0; i < part.size(); ++i) {
      samples_.push_back(part[i]);
      const auto& poses = aligned[i].poses;
      for (std::size_t p = 0; p < poses.size() && static_cast<int>(p / turns) < most; ++p) {
        const std::size_t k = p / turns;  // the pose's rank: a jaw's grasp line holds `turns` poses
        Candidate c;
        c.sample_index = static_cast<int>(samples_.size() - 1);
        c.pose = poses[p].pose();
        c.dofs = part[i];
        c.alignment_quality = poses[p].quality;
        c.votes = poses[p].votes;
        if (static_cast<int>(k) < first) {
          cands.push_back(std::move(c));
        } else {
          deeper_[k - static_cast<std::size_t>(first)].push_back(std::move(c));
        }
      }
    }
  }
  SearchStep step;
  step.samples = static_cast<long>(samples.size());
  step.align_seconds = seconds_since(t0);
  return run(std::move(cands), step);
}

int GraspSearch::deepen_rank() const {
  std::size_t r = deepen_rank_, next = deepen_next_;
  while (r < deeper_.size() && next >= deeper_[r].size()) ++r, next = 0;
  return r < deeper_.size() ? options_.poses_per_sample + static_cast<int>(r) : -1;
}

SearchStep GraspSearch::deepen(std::size_t max_candidates) {
  const detail::BusyGuard busy(busy_, "GraspSearch");
  while (deepen_rank_ < deeper_.size() && deepen_next_ >= deeper_[deepen_rank_].size()) ++deepen_rank_, deepen_next_ = 0;
  if (deepen_rank_ >= deeper_.size() || max_candidates == 0) return SearchStep();
  const std::vector<Candidate>& rank = deeper_[deepen_rank_];
  const std::size_t end = std::min(rank.size(), deepen_next_ + max_candidates);
  std::vector<Candidate> cands(rank.begin() + static_cast<long>(deepen_next_), rank.begin() + static_cast<long>(end));
  deepen_next_ = end;
  deepened_ += static_cast<long>(cands.size());
  return run(std::move(cands), SearchStep());
}

std::vector<int> GraspSearch::ranked_samples() const {
  const std::vector<EvaluatedCandidate>& ev = pipeline_.evaluated();
  std::vector<int> best(samples_.size(), -1);  // per sample: its best evaluated candidate
  for (std::size_t k = 0; k < ev.size(); ++k) {
    int& b = best[static_cast<std::size_t>(ev[k].candidate.sample_index)];
    if (b < 0 || ranks_before(ev[k], ev[static_cast<std::size_t>(b)])) b = static_cast<int>(k);
  }
  std::vector<int> out;
  for (std::size_t s = 0; s < best.size(); ++s)
    if (best[s] >= 0) out.push_back(static_cast<int>(s));
  std::stable_sort(out.begin(), out.end(), [&](int a, int b) {
    return ranks_before(ev[static_cast<std::size_t>(best[static_cast<std::size_t>(a)])],
                        ev[static_cast<std::size_t>(best[static_cast<std::size_t>(b)])]);
  });
  return out;
}

std::vector<RankedGrasp> GraspSearch::finish(std::optional<Clock::time_point> deadline, FinishTimings* timings) const {
  const detail::BusyGuard busy(busy_, "GraspSearch");
  FinishOptions fo = finish_;
  fo.deadline = deadline;
  return pipeline_.finish(fo, timings);
}

long GraspSearch::force_closure() const {
  long n = 0;
  for (const EvaluatedCandidate& c : pipeline_.evaluated()) n += c.evaluation.quality.force_closure;
  return n;
}

std::map<std::string, long> GraspSearch::counts() const {
  return {{"samples", total_.samples},   {"aligned_poses", total_.aligned_poses}, {"deepened_poses", deepened_},
          {"settled", total_.settled},   {"settled_aligned", total_.settled_aligned},
          {"evaluated", total_.evaluated}};
}

std::map<std::string, double> GraspSearch::timings() const {
  return {{"align", total_.align_seconds}, {"settle", total_.settle_seconds}, {"evaluate", total_.evaluate_seconds}};
}

PlanReport plan_samples(const GraspPlanner& planner, const std::vector<Eigen::VectorXd>& samples,
                        const PlanOptions& options) {
  GraspSearch search(planner, options);
  for (std::size_t k = 0; k < samples.size(); ++k) {
    try {
      planner.hand().link_poses(samples[k]);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("samples[" + std::to_string(k) + "]: " + e.what());
    }
  }
  const std::size_t chunk = static_cast<std::size_t>(search.options().chunk);
  for (std::size_t b = 0; b < samples.size(); b += chunk)
    search.add_samples(std::vector<Eigen::VectorXd>(samples.begin() + static_cast<long>(b),
                                                    samples.begin() + static_cast<long>(std::min(samples.size(), b + chunk))));
  PlanReport report;
  const auto t0 = Clock::now();
  FinishTimings ft;
  report.grasps = search.finish(std::nullopt, &ft);
  report.candidates = search.evaluated();
  report.counts = search.counts();
  report.counts["force_closure"] = search.force_closure();
  report.timings = search.timings();
  report.timings["fine_tune"] = seconds_since(t0) - ft.robust;
  report.timings["robust"] = ft.robust;
  return report;
}

}  // namespace pairgrasp
