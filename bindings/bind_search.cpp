// One plan's search: PlanOptions, GraspSearch (add_samples, deepen, finish) and plan_samples.
#include "bind.hpp"

#include <pairgrasp/search.hpp>

#include <chrono>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

namespace pairgrasp::py {

namespace {

using namespace pybind11::literals;


// PlanOptions from keyword arguments named as its fields (None: unset, for the derived ones);
// validate() then names the first bad value.
PlanOptions plan_options(const pyb::kwargs& kw) {
  PlanOptions o;
  for (const auto& item : kw) {
    const std::string k = pyb::str(item.first);
    const pyb::handle v = item.second;
    const bool none = v.is_none();
    if (k == "poses_per_sample") o.poses_per_sample = integer(v, k);
    else if (k == "max_poses_per_sample") o.max_poses_per_sample = integer(v, k);
    else if (k == "chunk") o.chunk = integer(v, k);
    else if (k == "step") o.step = none ? std::nullopt : std::optional<double>(real(v, k));
    else if (k == "backoff") o.backoff = none ? std::nullopt : std::optional<double>(real(v, k));
    else if (k == "top") o.top = integer(v, k);
    else if (k == "fine_tune") o.fine_tune = integer(v, k);
    else if (k == "fine_tune_iterations") o.fine_tune_iterations = integer(v, k);
    else if (k == "seed") o.seed = seed_value(v, k);
    else if (k == "mu") o.mu = real(v, k);
    else if (k == "edges") o.edges = integer(v, k);
    else if (k == "contacts_per_link") o.contacts_per_link = none ? 0 : integer(v, k);
    else if (k == "max_evaluations") o.max_evaluations = none ? std::nullopt : std::optional<int>(integer(v, k));
    else if (k == "hull_rank") o.hull_rank = none ? std::nullopt : std::optional<int>(integer(v, k));
    else if (k == "rank") o.rank = ranking_from_string(pyb::str(v));
    else if (k == "robust_samples") o.robust_samples = integer(v, k);
    else throw std::invalid_argument("unknown plan option '" + k + "'");
  }
  validate(o);
  return o;
}

pyb::dict step_dict(const SearchStep& s) {
  return pyb::dict("samples"_a = s.samples, "aligned_poses"_a = s.aligned_poses, "settled"_a = s.settled,
                   "settled_aligned"_a = s.settled_aligned, "evaluated"_a = s.evaluated,
                   "align_seconds"_a = s.align_seconds, "settle_seconds"_a = s.settle_seconds,
                   "evaluate_seconds"_a = s.evaluate_seconds);
}

const char* const kOptionsDoc =
    "Options (keywords, as C++ PlanOptions; None: derived): poses_per_sample (3), max_poses_per_sample (3: poses "
    "kept for deepen()), chunk (128, plan_samples), step (rad; None: the hand's), backoff (m; None: the planner's), "
    "top (10), fine_tune (5), fine_tune_iterations (20), seed (0), mu (0.5), edges (8), contacts_per_link (4; "
    "None or 0: every contact), max_evaluations (None: all), hull_rank (None: derived), rank, robust_samples (8).";

}  // namespace

void bind_search(pyb::module_& m) {
  pyb::class_<GraspSearch>(
      m, "GraspSearch",
      "One plan's search over a GraspPlanner: add_samples() aligns DOF samples and settles and evaluates their best "
      "poses, deepen() evaluates the next-ranked kept poses, finish() ranks and fine-tunes. It serves one caller at "
      "a time (a second thread's call while one runs raises RuntimeError).")
      .def(pyb::init([](const GraspPlanner& planner, const pyb::kwargs& kw) {
             return std::make_unique<GraspSearch>(planner, plan_options(kw));
           }),
           "planner"_a, kOptionsDoc)
      .def(
          "add_samples",
          [](GraspSearch& s, const pyb::object& samples, bool keep_deeper) {
            const std::vector<Eigen::VectorXd> qs = samples_from(samples, static_cast<long>(s.planner().hand().dofs().size()));
            SearchStep r;
            {
              pyb::gil_scoped_release release;
              r = s.add_samples(qs, keep_deeper);
            }
            return step_dict(r);
          },
          "samples"_a, "keep_deeper"_a = false,
          "Align the samples (K, D), settle and evaluate the best poses_per_sample poses of each (keep_deeper: keep "
          "the next ones up to max_poses_per_sample for deepen()). Returns a dict of what the call did.")
      .def_property_readonly("deepen_rank", &GraspSearch::deepen_rank,
                             "Rank (0-based, per sample) of the kept poses deepen() takes next; -1 when none is left.")
      .def(
          "deepen",
          [](GraspSearch& s, std::size_t max_candidates) {
            SearchStep r;
            {
              pyb::gil_scoped_release release;
              r = s.deepen(max_candidates);
            }
            return step_dict(r);
          },
          "max_candidates"_a, "Settle and evaluate the next kept poses of rank deepen_rank (at most max_candidates).")
      .def("ranked_samples", &GraspSearch::ranked_samples,
           "Indices of the samples with an evaluated candidate, best first by their best candidate.")
      .def(
          "finish",
          [](const GraspSearch& s, std::optional<double> time_left) {
            const auto deadline = deadline_after(time_left);
            return finish_released([&](FinishTimings* t) { return s.finish(deadline, t); });
          },
          "time_left"_a = pyb::none(),
          "Rank the evaluated candidates, fine-tune the best (no trial starts after time_left seconds) and return "
          "(at most top RankedGrasp, best first; {'fine_tune', 'robust'} seconds).")
      .def_property_readonly("samples", [](const GraspSearch& s) {
            const long d = static_cast<long>(s.planner().hand().dofs().size());
            pyb::array_t<double> a({static_cast<pyb::ssize_t>(s.samples().size()), static_cast<pyb::ssize_t>(d)});
            for (std::size_t k = 0; k < s.samples().size(); ++k)
              for (long j = 0; j < d; ++j) a.mutable_at(static_cast<pyb::ssize_t>(k), j) = s.samples()[k][j];
            return a;
          }, "(N, D) the samples added so far, in order.")
      .def(
          "evaluated",
          [](const GraspSearch& s, std::size_t start) {
            return std::vector<EvaluatedCandidate>(s.evaluated().begin() + static_cast<long>(std::min(start, s.evaluated().size())),
                                                   s.evaluated().end());
          },
          "start"_a = 0, "The evaluated candidates from index start on, in evaluation order.")
      .def_property_readonly("evaluated_count", [](const GraspSearch& s) { return s.evaluated().size(); })
      .def_property_readonly("force_closure", &GraspSearch::force_closure, "Evaluated candidates that are force-closure.")
      .def_property_readonly("counts", &GraspSearch::counts,
                             "Totals: samples, aligned_poses, deepened_poses, settled, settled_aligned, evaluated.")
      .def_property_readonly("timings", &GraspSearch::timings, "Seconds: align, settle, evaluate.")
      .def_property_readonly("backoff", [](const GraspSearch& s) { return *s.options().backoff; },
                             "The largest back-off used when settling (m).");

  m.def(
      "check_plan_options", [](const pyb::kwargs& kw) { plan_options(kw); },
      (std::string("Raises ValueError naming the first bad one of the plan options (C++ PlanOptions). ") + kOptionsDoc)
          .c_str());
  m.def(
      "plan_samples",
      [](const GraspPlanner& planner, const pyb::object& samples, const pyb::kwargs& kw) {
        const std::vector<Eigen::VectorXd> qs = samples_from(samples, static_cast<long>(planner.hand().dofs().size()));
        const PlanOptions o = plan_options(kw);
        PlanReport r;
        {
          pyb::gil_scoped_release release;
          r = plan_samples(planner, qs, o);
        }
        return pyb::make_tuple(r.grasps, r.candidates, r.counts, r.timings);
      },
      "planner"_a, "samples"_a,
      (std::string("The C++ planning call: a GraspSearch over the samples (K, D), `chunk` samples per add_samples, then "
                   "finish. Returns (grasps: list of RankedGrasp, candidates: list of EvaluatedCandidate, counts, timings). ") +
       kOptionsDoc).c_str());
}

}  // namespace pairgrasp::py
