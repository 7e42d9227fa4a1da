// Planning: evaluate_grasp, fine_tune, robust_quality, reduce_contacts, torque_reference, the batched
// CandidatePipeline (settle, deduplicate, evaluate, rank, fine-tune) and GraspPlanner / plan_samples.
#include "bind.hpp"

#include <pairgrasp/candidates.hpp>
#include <pairgrasp/evaluation.hpp>
#include <pairgrasp/search.hpp>
#include <pairgrasp/robust.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace pairgrasp::py {

namespace {

using namespace pybind11::literals;

std::optional<double> real_arg(const pyb::object& v, const char* name, bool allow_zero) {
  if (v.is_none()) return std::nullopt;
  if (pyb::isinstance<pyb::bool_>(v) || !(pyb::isinstance<pyb::float_>(v) || pyb::isinstance<pyb::int_>(v) ||
                                          pyb::hasattr(v, "__float__")))
    throw std::invalid_argument(std::string(name) + ": expected a real number, got " + std::string(pyb::repr(v)));
  const double x = v.cast<double>();
  if (!std::isfinite(x) || x < 0.0 || (!allow_zero && x == 0.0))
    throw std::invalid_argument(std::string(name) + ": expected a finite value " + (allow_zero ? ">= 0" : "> 0") +
                                ", got " + std::to_string(x));
  return x;
}

int count_arg(const pyb::object& v, const char* name, int low) {
  if (pyb::isinstance<pyb::bool_>(v) || !pyb::isinstance<pyb::int_>(v) || v.cast<long long>() < low)
    throw std::invalid_argument(std::string(name) + ": expected an integer >= " + std::to_string(low) + ", got " +
                                std::string(pyb::repr(v)));
  return v.cast<int>();
}

// A DeprecationWarning for a renamed Python name (raises if warnings are errors).
void deprecated(const std::string& old_name, const std::string& new_name) {
  const std::string message = old_name + " is deprecated: use " + new_name + " (the old name goes in the next release)";
  if (PyErr_WarnEx(PyExc_DeprecationWarning, message.c_str(), 1) != 0) throw pyb::error_already_set();
}

// The pool of every ranking but epsilon: rank_pool, or the deprecated robust_pool keyword.
int rank_pool_arg(int rank_pool, const pyb::object& robust_pool) {
  if (robust_pool.is_none()) return rank_pool;
  deprecated("robust_pool", "rank_pool");
  return integer(robust_pool, "robust_pool");
}

Eigen::VectorXd dofs_arg(const pyb::object& v, const Hand& hand) {
  Eigen::VectorXd q = vector_from(v, "dofs");
  if (q.size() != static_cast<Eigen::Index>(hand.dofs().size()))
    throw std::invalid_argument("dofs: expected " + std::to_string(hand.dofs().size()) + " values, got " +
                                std::to_string(q.size()));
  return q;
}

// The scoring options from the keyword arguments shared by evaluate_grasp and fine_tune.
EvaluateOptions evaluate_options(const pyb::object& center, const pyb::object& radius, double mu, int edges,
                                 bool soft, std::optional<double> torsion, const pyb::object& contacts_per_link,
                                 const GraspChecker& checker) {
  EvaluateOptions o;
  o.quality.contact.mu = mu;
  o.quality.contact.edges = edges;
  o.quality.contact.soft = soft;
  o.quality.contact.torsion = torsion;
  if (!center.is_none() || !radius.is_none()) {
    TorqueReference ref = center.is_none() || radius.is_none() ? torque_reference(checker.target()) : TorqueReference();
    if (!center.is_none()) {
      const Eigen::VectorXd c = vector_from(center, "center");
      if (c.size() != 3) throw std::invalid_argument("center: expected 3 values, got " + std::to_string(c.size()));
      ref.center = c;
    }
    if (!radius.is_none()) ref.radius = radius.cast<double>();
    o.reference = ref;
  }
  o.contacts_per_link = contacts_per_link.is_none() ? 0 : count_arg(contacts_per_link, "contacts_per_link", 1);
  return o;
}

pyb::tuple names_of(const GraspEvaluation& e) {
  pyb::tuple t(e.contacts.link_names.size());
  for (std::size_t i = 0; i < e.contacts.link_names.size(); ++i) t[i] = e.contacts.link_names[i];
  return t;
}

pyb::array_t<double> pose_array(const Pose& p) {
  pyb::array_t<double> a({4, 4});
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) a.mutable_at(i, j) = p.matrix()(i, j);
  a.attr("setflags")("write"_a = false);
  return a;
}

const char* const kEvaluateDoc =
    "Close, check and score one grasp: close the closing DOFs onto contact (close=False: evaluate `dofs` as "
    "given), check penetration and pruning at the closed DOFs, find the contacts on free faces and compute their "
    "Ferrari-Canny epsilon. A pruned grasp is not scored (epsilon 0, not force-closure, quality_reason "
    "'pruned: ...').\n\n"
    "wrist_pose: (4,4) rigid wrist pose in the target frame. dofs: (D,) within the limits. center, radius: torque "
    "origin and scale (m; default the target's centre of mass and largest vertex distance from it). mu, edges, "
    "soft, torsion: the friction model (as grasp_quality). contacts_per_link: score at most this many contacts per "
    "link (reduce_contacts: a lower bound of epsilon, an order of magnitude faster on the Barrett hand's ~100-"
    "contact patches, and no hull volume for a grasp that is not force-closure); None: every contact. Raises "
    "ValueError for a pose that is not a finite rigid transform, bad DOFs or bad quality parameters.";

const char* const kFineTuneDoc =
    "Local random search around a grasp for a better epsilon. The start is closed and scored; each of "
    "`iterations` trials perturbs the starting grasp by a translation uniform in the ball of radius `translation` "
    "(default facet_size / 2), a rotation by an angle uniform in [-angle_deg, angle_deg] degrees about a random "
    "axis through the centroid of the start's contacts, and DOF values uniform within step / 2 of `dofs` "
    "(default step: the hand's dof_step; 0 keeps a DOF fixed), clamped to the limits; closes again and keeps the "
    "best grasp (unpruned, then force-closure, then epsilon, then volume; strictly better only). The trials come "
    "from std::mt19937_64(seed), drawn before any is evaluated: the same result on every platform and thread "
    "count. Returns FineTuneResult (best is never pruned; None when the start is pruned and no trial is not).";

ConstellationChoice choice_from(const std::string& c) {
  if (c == "auto") return ConstellationChoice::Auto;
  if (c == "per_link") return ConstellationChoice::PerLink;
  if (c == "area") return ConstellationChoice::Area;
  if (c == "antipodal") return ConstellationChoice::Antipodal;
  throw std::invalid_argument("constellation: expected 'auto', 'per_link', 'area' or 'antipodal', got '" + c + "'");
}

// PlannerOptions from keyword arguments named as its fields (None: unset, derived).
PlannerOptions planner_options(const pyb::kwargs& kw) {
  PlannerOptions o;
  auto length = [](const pyb::handle& v, const std::string& k) {
    return v.is_none() ? std::nullopt : std::optional<double>(real(v, k));
  };
  for (const auto& item : kw) {
    const std::string k = pyb::str(item.first);
    const pyb::handle v = item.second;
    if (k == "edge") o.edge = length(v, k);
    else if (k == "d_max") o.d_max = length(v, k);
    else if (k == "max_pairs") o.max_pairs = static_cast<std::size_t>(std::max(0, integer(v, k)));
    else if (k == "max_pairs_per_cell")
      o.max_pairs_per_cell = static_cast<std::size_t>(count_arg(pyb::reinterpret_borrow<pyb::object>(v), k.c_str(), 0));
    else if (k == "constellation") o.constellation = choice_from(pyb::str(v));
    else if (k == "spacing") o.spacing = length(v, k);
    else if (k == "max_area_samples") o.max_area_samples = integer(v, k);
    else if (k == "depth_tolerance") o.depth_tolerance = length(v, k);
    else if (k == "gap") o.gap = real(v, k);
    else if (k == "backoff") o.backoff = length(v, k);
    else if (k == "field_cell") o.field_cell = length(v, k);
    else if (k == "max_field_bytes") {
      const double bytes = real(v, k);
      if (!(bytes >= 1.0 && bytes < 1e18))
        throw std::invalid_argument("max_field_bytes: expected a number of bytes >= 1, got " + std::string(pyb::repr(v)));
      o.max_field_bytes = static_cast<std::size_t>(bytes);
    }
    else if (k == "mu") o.mu = real(v, k);
    else if (k == "threads") o.threads = integer(v, k);
    else throw std::invalid_argument("unknown planner option '" + k + "'");
  }
  validate(o);
  return o;
}

const char* mode_name(const PlannerSetup& s) {
  return s.antipodal ? "antipodal" : s.mode == ConstellationMode::Area ? "area" : "per_link";
}


const char* const kPlannerOptionsDoc =
    "Options (keywords, as C++ PlannerOptions; None: derived): edge (m), d_max (m; None: the hand's span + edge), "
    "max_pairs, max_pairs_per_cell (about this many pairs kept per cell of the feature space; 0: all), constellation ('auto', 'per_link', 'area', 'antipodal'), spacing (m), max_area_samples, depth_tolerance (m; None: "
    "edge / 4), gap (m), field_cell (m; None: max(edge / 5, 1 mm)), max_field_bytes (2 GiB), backoff (m; None: half the "
    "hand's reach; a GraspSearch may use another), mu (0.5: the friction of the searches it serves; free faces that "
    "cannot hold a force-closure grasp at it within the hand's contact span are not indexed, see graspable_faces), "
    "threads (0: every core).";

}  // namespace

void bind_planning(pyb::module_& m) {
  pyb::tuple rankings(std::size(kRankings));
  for (std::size_t i = 0; i < std::size(kRankings); ++i) rankings[i] = pyb::str(to_string(kRankings[i]));
  m.attr("RANKINGS") = rankings;
  m.attr("DEFAULT_RANK") = to_string(FinishOptions().rank);
  pyb::class_<GraspEvaluation>(m, "GraspEvaluation", "A grasp closed onto contact, checked and scored (evaluate_grasp).")
      .def_property_readonly("wrist_pose", [](const GraspEvaluation& e) { return pose_array(e.wrist); },
                             "(4,4) wrist pose in the target frame.")
      .def_property_readonly("dofs", [](pyb::object self) { return readonly_view(self.cast<const GraspEvaluation&>().dofs, self); },
                             "(D,) DOF values evaluated (the closed values when closed).")
      .def_property_readonly("start_dofs", [](pyb::object self) { return readonly_view(self.cast<const GraspEvaluation&>().start_dofs, self); },
                             "(D,) DOF values before closing.")
      .def_readonly("pruned", &GraspEvaluation::pruned,
                    "Penetration beyond the tolerance, an obstacle collision or a link touching occluded faces.")
      .def_readonly("depth", &GraspEvaluation::depth, "Largest penetration depth over links, target and obstacles (m).")
      .def_readonly("target_depth", &GraspEvaluation::target_depth, "Largest penetration depth into the target (m).")
      .def_readonly("reason", &GraspEvaluation::reason, "Why it is pruned ('' when kept).")
      .def_property_readonly("contact_points", [](pyb::object self) { return readonly_view(self.cast<const GraspEvaluation&>().contacts.points, self); },
                             "(C,3) contact points on the hand's active surfaces, target frame (m).")
      .def_property_readonly("contact_normals", [](pyb::object self) { return readonly_view(self.cast<const GraspEvaluation&>().contacts.normals, self); },
                             "(C,3) unit outward target normals at the contacts.")
      .def_property_readonly("contact_links", &names_of, "Names of the links making each contact.")
      .def_property_readonly("occluded_contacts", [](const GraspEvaluation& e) { return e.contacts.occluded_count; },
                             "Contacts found on occluded faces (not scored).")
      .def_property_readonly("n_contacts", [](const GraspEvaluation& e) { return e.contacts.points.rows(); },
                             "Number of contacts on free faces.")
      .def_property_readonly("epsilon", [](const GraspEvaluation& e) { return e.quality.epsilon; },
                             "Ferrari-Canny epsilon (0 when pruned or not force-closure).")
      .def_property_readonly("volume", [](const GraspEvaluation& e) { return e.quality.volume; },
                             "6-D volume of the grasp wrench hull (0 when pruned).")
      .def_property_readonly("force_closure", [](const GraspEvaluation& e) { return e.quality.force_closure; })
      .def_property_readonly("epsilon_computed", [](const GraspEvaluation& e) { return e.quality.epsilon_computed; },
                             "False when epsilon is a lower bound because the grasp provably cannot reach the "
                             "pipeline's best (CandidatePipeline hull_rank).")
      .def_property_readonly("quality_reason", [](const GraspEvaluation& e) { return e.quality.reason; },
                             "Why it is not force-closure ('' when it is; 'pruned: ...' when pruned).")
      .def_property_readonly("closing_reasons", [](const GraspEvaluation& e) {
            pyb::tuple t(e.closing.size());
            for (std::size_t i = 0; i < e.closing.size(); ++i) t[i] = to_string(e.closing[i]);
            return t;
          }, "Why each DOF stopped closing ('contact', 'limit', 'blocked', 'fixed'); () when not closed.")
      .def_readonly("check", &GraspEvaluation::check, "CheckResult at (wrist_pose, dofs).")
      .def_readonly("contacts", &GraspEvaluation::contacts, "Contacts at (wrist_pose, dofs).")
      .def("__repr__", [](const GraspEvaluation& e) {
        std::string s = "GraspEvaluation(pruned=" + std::string(e.pruned ? "True" : "False") +
                        ", epsilon=" + std::to_string(e.quality.epsilon) +
                        ", force_closure=" + (e.quality.force_closure ? "True" : "False") +
                        ", contacts=" + std::to_string(e.contacts.points.rows()) + ", depth=" + std::to_string(e.depth);
        if (!e.reason.empty()) s += ", reason='" + e.reason + "'";
        return s + ")";
      });

  pyb::class_<FineTuneResult>(m, "FineTuneResult", "Result of fine_tune.")
      .def_readonly("best", &FineTuneResult::best, "The best GraspEvaluation found (never pruned), or None.")
      .def_readonly("start", &FineTuneResult::start, "The starting grasp, closed and scored.")
      .def_readonly("trials", &FineTuneResult::trials)
      .def_readonly("kept", &FineTuneResult::kept, "Trials that were not pruned.")
      .def_readonly("improvements", &FineTuneResult::improvements, "Trials that replaced the best so far.")
      .def_readonly("improved", &FineTuneResult::improved, "The best grasp is a trial strictly better than the start.")
      .def_readonly("reason", &FineTuneResult::reason, "'' when best is set, else why nothing is returned.")
      .def_property_readonly("found", [](const FineTuneResult& r) { return r.best.has_value(); })
      .def_property_readonly("epsilon", [](const FineTuneResult& r) { return r.best ? r.best->quality.epsilon : 0.0; })
      .def("__repr__", [](const FineTuneResult& r) {
        return "FineTuneResult(epsilon=" + std::to_string(r.best ? r.best->quality.epsilon : 0.0) +
               ", trials=" + std::to_string(r.trials) + ", kept=" + std::to_string(r.kept) +
               ", improved=" + (r.improved ? "True" : "False") + ")";
      });

  m.def(
      "evaluate_grasp",
      [](const GraspChecker& checker, const pyb::object& wrist_pose, const pyb::object& dofs, const pyb::object& center,
         const pyb::object& radius, double mu, int edges, bool close, bool soft, std::optional<double> torsion,
         const pyb::object& contacts_per_link) {
        const Pose w = pose_from(wrist_pose, "wrist_pose");
        const Eigen::VectorXd q = dofs_arg(dofs, checker.hand());
        EvaluateOptions o = evaluate_options(center, radius, mu, edges, soft, torsion, contacts_per_link, checker);
        o.close = close;
        pyb::gil_scoped_release release;
        return evaluate_grasp(checker, w, q, o);
      },
      "checker"_a, "wrist_pose"_a, "dofs"_a, "center"_a = pyb::none(), "radius"_a = pyb::none(), "mu"_a = ContactModel().mu,
      "edges"_a = ContactModel().edges, "close"_a = true, "soft"_a = ContactModel().soft,
      "torsion"_a = pyb::none(), "contacts_per_link"_a = pyb::none(),
      kEvaluateDoc);

  m.def(
      "fine_tune",
      [](const GraspChecker& checker, const pyb::object& wrist_pose, const pyb::object& dofs, const pyb::object& step,
         const pyb::object& facet_size, const pyb::object& iterations, std::uint64_t seed, const pyb::object& angle_deg,
         const pyb::object& translation, const pyb::object& center, const pyb::object& radius, double mu, int edges,
         bool soft, std::optional<double> torsion, const pyb::object& contacts_per_link, int threads) {
        const Pose w = pose_from(wrist_pose, "wrist_pose");
        const Eigen::VectorXd q = dofs_arg(dofs, checker.hand());
        FineTuneOptions o;
        if (!step.is_none()) {
          const DoubleArray s = as_double_array(step, "step");
          if (s.ndim() == 0) {
            o.steps = Eigen::VectorXd::Constant(q.size(), *s.data());
          } else {
            if (s.ndim() != 1 || s.shape(0) != q.size())
              throw std::invalid_argument("step: expected " + std::to_string(q.size()) + " values, got shape " + shape_of(s));
            o.steps = Eigen::Map<const Eigen::VectorXd>(s.data(), q.size());
          }
        }
        const std::optional<double> h = real_arg(facet_size, "facet_size", false);
        const std::optional<double> t = real_arg(translation, "translation", true);
        if (!t && !h) throw std::invalid_argument("facet_size: needed (the unit-facet edge h, metres) unless translation is given");
        o.translation = t ? *t : *h / 2.0;
        o.angle = *real_arg(angle_deg, "angle_deg", true) * 3.14159265358979323846 / 180.0;
        o.iterations = count_arg(iterations, "iterations", 0);
        o.seed = seed;
        o.threads = threads;
        o.evaluate = evaluate_options(center, radius, mu, edges, soft, torsion, contacts_per_link, checker);
        pyb::gil_scoped_release release;
        return fine_tune(checker, w, q, o);
      },
      "checker"_a, "wrist_pose"_a, "dofs"_a, "step"_a = pyb::none(), "facet_size"_a = pyb::none(),
      "iterations"_a = 30, "seed"_a = 0, "angle_deg"_a = 3.0, "translation"_a = pyb::none(), "center"_a = pyb::none(),
      "radius"_a = pyb::none(), "mu"_a = ContactModel().mu, "edges"_a = ContactModel().edges,
      "soft"_a = ContactModel().soft, "torsion"_a = pyb::none(),
      "contacts_per_link"_a = pyb::none(), "threads"_a = 1, kFineTuneDoc);

  pyb::class_<RobustQuality>(m, "RobustQuality", "Force closure and epsilon under perturbations (robust_quality).")
      .def_readonly("force_closure_probability", &RobustQuality::force_closure_probability,
                    "Fraction of the samples that are force-closure.")
      .def_readonly("epsilon", &RobustQuality::epsilon, "The quantile of the samples' epsilons.")
      .def_readonly("mean_epsilon", &RobustQuality::mean_epsilon)
      .def_readonly("samples", &RobustQuality::samples)
      .def_readonly("backed_off", &RobustQuality::backed_off,
                    "Samples whose start pose penetrated and backed off along the approach axis.")
      .def_readonly("pruned", &RobustQuality::pruned, "Samples pruned after closing (counted as failures).")
      .def_readonly("epsilons", &RobustQuality::epsilons, "Per sample (0 when pruned).")
      .def("__repr__", [](const RobustQuality& r) {
        return "RobustQuality(force_closure_probability=" + std::to_string(r.force_closure_probability) +
               ", epsilon=" + std::to_string(r.epsilon) + ", samples=" + std::to_string(r.samples) +
               ", pruned=" + std::to_string(r.pruned) + ")";
      });

  m.def(
      "robust_quality",
      [](const GraspChecker& checker, const pyb::object& wrist_pose, const pyb::object& dofs, const pyb::object& samples,
         double translation_sigma, double rotation_sigma_deg, double friction_spread, double quantile,
         std::uint64_t seed, const pyb::object& center, const pyb::object& radius, double mu, int edges,
         const pyb::object& contacts_per_link, int threads) {
        const Pose w = pose_from(wrist_pose, "wrist_pose");
        const Eigen::VectorXd q = dofs_arg(dofs, checker.hand());
        RobustOptions o;
        o.samples = count_arg(samples, "samples", 1);
        o.translation_sigma = translation_sigma;
        o.rotation_sigma = rotation_sigma_deg * 3.14159265358979323846 / 180.0;
        o.friction_spread = friction_spread;
        o.quantile = quantile;
        o.seed = seed;
        o.threads = threads;
        o.evaluate = evaluate_options(center, radius, mu, edges, false, std::nullopt, contacts_per_link, checker);
        pyb::gil_scoped_release release;
        return robust_quality(checker, w, q, o);
      },
      "checker"_a, "wrist_pose"_a, "dofs"_a, "samples"_a = RobustOptions().samples,
      "translation_sigma"_a = RobustOptions().translation_sigma, "rotation_sigma_deg"_a = 1.0,
      "friction_spread"_a = RobustOptions().friction_spread, "quantile"_a = RobustOptions().quantile, "seed"_a = 0,
      "center"_a = pyb::none(), "radius"_a = pyb::none(), "mu"_a = ContactModel().mu, "edges"_a = ContactModel().edges,
      "contacts_per_link"_a = pyb::none(), "threads"_a = 1,
      "How a grasp's force closure and epsilon hold up under execution and model error: the grasp (wrist_pose, and "
      "dofs: the DOF values before closing) is closed and scored again at `samples` perturbations, each the wrist "
      "turned by N(0, rotation_sigma_deg) degrees about a random axis through the wrist origin and moved by "
      "N(0, translation_sigma) m per axis, with friction uniform in [mu (1 - friction_spread), mu (1 + "
      "friction_spread)]. A sample whose start pose penetrates backs off along the approach axis (0.5 mm steps, at "
      "most 3 mm); one still pruned after closing is a failure. Returns RobustQuality: the fraction of "
      "force-closure samples and the `quantile` of their epsilons. Drawn from std::mt19937_64(seed) before any is "
      "evaluated: the same on every platform and thread count.");

  m.def(
      "reduce_contacts",
      [](const pyb::object& points, const pyb::sequence& links, const pyb::object& per_link) {
        const Points p = points_from(points, "points");
        std::vector<int> ids;
        pyb::dict index;  // link name (or any hashable) -> small integer, in order of first appearance
        for (const pyb::handle item : links) {
          if (!index.contains(item)) index[item] = pyb::int_(index.size());
          ids.push_back(index[item].cast<int>());
        }
        const int k = count_arg(per_link, "per_link", 1);
        std::vector<int> keep;
        {
          pyb::gil_scoped_release release;
          keep = reduce_contacts(p, ids, k);
        }
        return pyb::array_t<long>(static_cast<pyb::ssize_t>(keep.size()), std::vector<long>(keep.begin(), keep.end()).data());
      },
      "points"_a, "links"_a, "per_link"_a,
      "Indices (sorted) of at most `per_link` contacts per link (`links`: the link of each contact), spread by "
      "farthest-point sampling from the link's contact centroid (ties: the lowest index). The hull of the kept "
      "contacts' wrenches lies inside the hull of all of them, so epsilon from them is a lower bound.");

  m.def(
      "torque_reference",
      [](const Mesh& mesh) {
        const TorqueReference r = torque_reference(mesh);
        return pyb::make_tuple(Eigen::Vector3d(r.center), r.radius);
      },
      "mesh"_a,
      "The default torque origin and scale of epsilon for a target mesh: (its centre of mass (m), the largest "
      "distance (m) of its vertices from it).");

  pyb::class_<Candidate>(m, "AlignedCandidate", "An aligned candidate (C++ Candidate), the input of CandidatePipeline.process.")
      .def(pyb::init([](const pyb::object& pose, const pyb::object& dofs, int sample_index, double alignment_quality,
                        int votes) {
             Candidate c;
             c.pose = pose_from(pose, "pose");
             c.dofs = vector_from(dofs, "dofs");
             if (!c.dofs.allFinite()) throw std::invalid_argument("dofs: expected finite values");
             if (sample_index < 0)
               throw std::invalid_argument("sample_index: expected an integer >= 0, got " + std::to_string(sample_index));
             if (!std::isfinite(alignment_quality))
               throw std::invalid_argument("alignment_quality: expected a finite value");
             c.sample_index = sample_index;
             c.alignment_quality = alignment_quality;
             c.votes = votes;
             return c;
           }),
           "pose"_a, "dofs"_a, "sample_index"_a = 0, "alignment_quality"_a = 0.0, "votes"_a = 0,
           "pose: (4,4) aligned wrist pose (target frame, metres); dofs: (D,) DOF sample (radians or metres).")
      .def_readonly("sample_index", &Candidate::sample_index, "Index of the DOF sample it came from.")
      .def_property_readonly("pose", [](const Candidate& c) { return pose_array(c.pose); }, "(4,4) aligned wrist pose.")
      .def_property_readonly("dofs", [](const Candidate& c) { return Eigen::VectorXd(c.dofs); }, "(D,) the DOF sample.")
      .def_readonly("alignment_quality", &Candidate::alignment_quality, "Q_A of its alignment (paper eq. 8).")
      .def_readonly("votes", &Candidate::votes, "Rotation votes of the alignment.");

  pyb::class_<EvaluatedCandidate>(m, "EvaluatedCandidate", "A candidate settled and evaluated by CandidatePipeline.")
      .def_property_readonly("sample_index", [](const EvaluatedCandidate& c) { return c.candidate.sample_index; },
                             "Index of the DOF sample it came from.")
      .def_property_readonly("sample", [](const EvaluatedCandidate& c) {
            deprecated("EvaluatedCandidate.sample", "sample_index");
            return c.candidate.sample_index;
          }, "Deprecated name of sample_index.")
      .def_property_readonly("pose", [](const EvaluatedCandidate& c) { return pose_array(c.candidate.pose); },
                             "(4,4) aligned wrist pose.")
      .def_property_readonly("dofs", [](const EvaluatedCandidate& c) { return Eigen::VectorXd(c.candidate.dofs); },
                             "(D,) the DOF sample.")
      .def_property_readonly("alignment_quality", [](const EvaluatedCandidate& c) { return c.candidate.alignment_quality; },
                             "Q_A of its alignment (paper eq. 8).")
      .def_property_readonly("quality", [](const EvaluatedCandidate& c) {
            deprecated("EvaluatedCandidate.quality", "alignment_quality");
            return c.candidate.alignment_quality;
          }, "Deprecated name of alignment_quality.")
      .def_property_readonly("votes", [](const EvaluatedCandidate& c) { return c.candidate.votes; })
      .def_property_readonly("settled", [](const EvaluatedCandidate& c) { return to_string(c.settled); },
                             "'aligned' or 'adjusted'.")
      .def_property_readonly("start_pose", [](const EvaluatedCandidate& c) { return pose_array(c.start_pose); },
                             "(4,4) settled wrist pose.")
      .def_property_readonly("start_dofs", [](const EvaluatedCandidate& c) { return Eigen::VectorXd(c.start_dofs); })
      .def_readonly("backoff", &EvaluatedCandidate::backoff, "Distance backed off along the approach axis (m).")
      .def_readonly("evaluation", &EvaluatedCandidate::evaluation)
      .def_readonly("seconds", &EvaluatedCandidate::seconds,
                    "Seconds from the pipeline's creation until its evaluation finished.");

  pyb::class_<RankedGrasp>(m, "RankedGrasp", "A grasp returned by CandidatePipeline.finish.")
      .def_readonly("candidate", &RankedGrasp::candidate, "Index into CandidatePipeline.evaluated.")
      .def_readonly("evaluation", &RankedGrasp::evaluation)
      .def_readonly("fine_tuned", &RankedGrasp::fine_tuned)
      .def_readonly("robust", &RankedGrasp::robust, "RobustQuality (robust ranking), or None.")
      .def_property_readonly("epsilon", [](const RankedGrasp& g) { return g.quality.epsilon; }, "From every contact.")
      .def_property_readonly("volume", [](const RankedGrasp& g) { return g.quality.volume; })
      .def_property_readonly("force_closure", [](const RankedGrasp& g) { return g.quality.force_closure; })
      .def_readonly("load_resistance", &RankedGrasp::load_resistance,
                    "Least pure force at the centre of mass along the six load directions, every contact.")
      .def_readonly("push", &RankedGrasp::push,
                    "closing_push() of every contact: ClosingPush (opposition, drive), least over the closing DOFs.");

  pyb::class_<CandidatePipeline>(
      m, "CandidatePipeline",
      "The candidate pipeline in C++: per chunk, settle each aligned candidate out of penetration (back off along "
      "the approach axis, open the penetrating fingers), deduplicate, close onto contact, find the contacts and score "
      "epsilon, on the shared thread pool; finish() ranks, fine-tunes and returns the grasps. It keeps a reference to "
      "the checker.")
      .def(pyb::init([](const GraspChecker& checker, double edge, double backoff, const pyb::object& steps,
                        const pyb::object& center, const pyb::object& radius, double mu, int edges,
                        const pyb::object& contacts_per_link, int max_evaluations, int hull_rank, int threads) {
             PipelineOptions o;
             o.edge = edge;
             o.backoff = backoff;
             if (!steps.is_none()) o.steps = vector_from(steps, "steps");
             o.evaluate = evaluate_options(center, radius, mu, edges, false, std::nullopt, contacts_per_link, checker);
             o.max_evaluations = max_evaluations;
             o.hull_rank = hull_rank;
             o.threads = threads;
             return std::make_unique<CandidatePipeline>(checker, o);
           }),
           "checker"_a, "edge"_a, "backoff"_a, "steps"_a = pyb::none(), "center"_a = pyb::none(),
           "radius"_a = pyb::none(), "mu"_a = ContactModel().mu, "edges"_a = ContactModel().edges,
           "contacts_per_link"_a = pyb::none(),
           "max_evaluations"_a = -1, "hull_rank"_a = 0, "threads"_a = 0, pyb::keep_alive<1, 2>())
      .def(
          "process",
          [](CandidatePipeline& p, const std::vector<Candidate>& candidates) {
            const std::size_t D = p.options().steps.size();
            for (std::size_t k = 0; k < candidates.size(); ++k)
              if (static_cast<std::size_t>(candidates[k].dofs.size()) != D)
                throw std::invalid_argument("candidates[" + std::to_string(k) + "].dofs: expected " +
                                            std::to_string(D) + " values, got " +
                                            std::to_string(candidates[k].dofs.size()));
            ChunkReport r;
            {
              pyb::gil_scoped_release release;
              r = p.process(candidates);
            }
            return pyb::dict("settled"_a = r.settled, "settled_aligned"_a = r.settled_aligned,
                             "evaluated"_a = r.evaluated, "checks"_a = r.checks, "settle_seconds"_a = r.settle_seconds,
                             "evaluate_seconds"_a = r.evaluate_seconds);
          },
          "candidates"_a,
          "Settle, deduplicate and evaluate a chunk of aligned candidates (a list of AlignedCandidate); the evaluated ones are "
          "appended to `evaluated`. Returns a dict of counts and the seconds of the settle and evaluate phases.")
      .def(
          "process",
          [](pyb::object self, const pyb::object& poses, const pyb::object& dofs, const pyb::object& samples,
             const pyb::object& qualities, const pyb::object& votes) {
            deprecated("CandidatePipeline.process(poses, dofs, samples, qualities, votes)",
                       "process([AlignedCandidate(...), ...])");
            const DoubleArray P = as_double_array(poses, "poses");
            const pyb::ssize_t K = P.ndim() == 3 ? P.shape(0) : -1;
            if (K < 0 || P.shape(1) != 4 || P.shape(2) != 4)
              throw std::invalid_argument("poses: expected a (K, 4, 4) array, got shape " + shape_of(P));
            const DoubleArray Q = as_double_array(dofs, "dofs");
            const Eigen::VectorXd S = vector_from(samples, "samples"), A = vector_from(qualities, "qualities"),
                                  V = vector_from(votes, "votes");
            if (Q.ndim() != 2 || Q.shape(0) != K || S.size() != K || A.size() != K || V.size() != K)
              throw std::invalid_argument("poses, dofs, samples, qualities, votes: expected " + std::to_string(K) +
                                          " of each");
            std::vector<Candidate> cands(static_cast<std::size_t>(K));
            for (pyb::ssize_t k = 0; k < K; ++k) {
              cands[k].pose = pose_from_data(P.data() + 16 * k, "poses[" + std::to_string(k) + "]");
              cands[k].dofs = Eigen::Map<const Eigen::VectorXd>(Q.data() + Q.shape(1) * k, Q.shape(1));
              cands[k].sample_index = static_cast<int>(S[k]);
              cands[k].alignment_quality = A[k];
              cands[k].votes = static_cast<int>(V[k]);
            }
            return self.attr("process")(cands);
          },
          "poses"_a, "dofs"_a, "samples"_a, "qualities"_a, "votes"_a,
          "Deprecated form of process(candidates): poses (K,4,4), DOF samples (K,D), sample indices, Q_A and votes (K,).")
      .def_property_readonly("fixed_links", [](const CandidatePipeline& p) {
            return std::vector<bool>(p.fixed_links().begin(), p.fixed_links().end());
          }, "Per link (Hand.links order): no closing DOF moves it (the palm group that backing off clears).")
      .def_property_readonly("dof_links", [](const CandidatePipeline& p) {
            std::vector<std::vector<bool>> out;
            for (const auto& m : p.dof_links()) out.emplace_back(m.begin(), m.end());
            return out;
          }, "Per DOF, per link: the DOF moves the link.")
      .def_property_readonly("evaluated_count", [](const CandidatePipeline& p) { return p.evaluated().size(); })
      .def(
          "evaluated",
          [](const CandidatePipeline& p, std::size_t start) {
            std::vector<EvaluatedCandidate> out;
            for (std::size_t k = start; k < p.evaluated().size(); ++k) out.push_back(p.evaluated()[k]);
            return out;
          },
          "start"_a = 0, "The evaluated candidates from index `start` on, in evaluation order.")
      .def(
          "finish",
          [](const CandidatePipeline& p, int top, int fine_tune, int iterations, std::uint64_t seed,
             std::optional<double> time_left, const std::string& rank, int robust_samples, int rank_pool,
             const pyb::object& robust_pool) {
            FinishOptions o;
            o.top = top;
            o.fine_tune = fine_tune;
            o.fine_tune_iterations = iterations;
            o.seed = seed;
            o.rank = ranking_from_string(rank);
            o.robust.samples = robust_samples;
            o.rank_pool = rank_pool_arg(rank_pool, robust_pool);
            o.deadline = deadline_after(time_left);
            return finish_released([&](FinishTimings* t) { return p.finish(o, t); });
          },
          "top"_a, "fine_tune"_a, "fine_tune_iterations"_a, "seed"_a, "time_left"_a = pyb::none(),
          "rank"_a = to_string(FinishOptions().rank), "robust_samples"_a = RobustOptions().samples,
          "rank_pool"_a = FinishOptions().rank_pool, "robust_pool"_a = pyb::none(),
          "Rank the evaluated candidates, fine-tune the `fine_tune` best (seed + rank; none starts after `time_left` "
          "seconds), drop near-duplicates, score them with every contact and return (at most `top` RankedGrasp, best "
          "first; {'fine_tune', 'robust'} seconds). Every rank but 'epsilon' picks from the pool, the max(top, rank_pool) best by epsilon (robust_pool: its deprecated name). rank 'robust': the pool is scored "
          "by robust_quality (robust_samples each) and ranked by force-closure probability, then robust epsilon; "
          "'epsilon': by force closure and epsilon; 'enclosure': rank 1 is the pool's force-closure grasp with the most "
          "hand links in contact, the others follow as 'epsilon' orders them; 'load': as 'enclosure', rank 1 the one with "
          "the largest load resistance.");

  pyb::class_<PlannerSetup>(m, "PlannerSetup", "Parameters resolved from the hand and the target (resolve_planner).")
      .def_readonly("edge", &PlannerSetup::edge, "Unit-facet edge (m).")
      .def_readonly("d_max", &PlannerSetup::d_max, "Largest stored pair distance (m).")
      .def_property_readonly("mode", [](const PlannerSetup& s) { return mode_name(s); },
                             "'per_link', 'area' or 'antipodal' (per-link samples of a parallel jaw on antipodal pairs).")
      .def_readonly("spacing", &PlannerSetup::spacing, "Area spacing (m; 0 for per-link constellations).")
      .def_readonly("depth_tolerance", &PlannerSetup::depth_tolerance, "m")
      .def_readonly("backoff", &PlannerSetup::backoff, "Largest back-off when settling (m).")
      .def_readonly("reach", &PlannerSetup::reach, "Largest distance of a constellation sample from the wrist (m).")
      .def_readonly("field_cell", &PlannerSetup::field_cell, "Cell edge of the checker's distance fields (m).")
      .def_readonly("distance_fields", &PlannerSetup::distance_fields,
                    "Whether the checker works on distance fields (not for an antipodal jaw, checked exactly).")
      .def_readonly("contact_span", &PlannerSetup::contact_span,
                    "Largest distance between two points of the active surfaces over the DOF range, plus the edge (m).")
      .def_readonly("free_faces", &PlannerSetup::free_faces, "Free faces of the target.")
      .def_readonly("graspable_faces", &PlannerSetup::graspable_faces,
                    "Free faces that may hold a contact of a force-closure grasp (graspable_faces): the index pairs "
                    "only their unit facets.");

  m.def(
      "check_planner_options", [](const pyb::kwargs& kw) { planner_options(kw); },
      (std::string("Raises ValueError naming the first bad one of the planner options (C++ PlannerOptions). ") +
       kPlannerOptionsDoc)
          .c_str());
  m.def("hand_span", &hand_span, "hand"_a,
        "The largest distance between two per-link constellation samples over the hand's DOF range (m).");
  m.def("finest_edge", &finest_edge, "target"_a,
        "The finest unit-facet edge the planner derives for the target (m): 5 mm, or a fifteenth of its smallest "
        "extent when that is less. A derived edge only grows from here, so a quarter of it bounds the derived depth "
        "tolerance from below.");
  m.def(
      "resolve_planner",
      [](const Hand& hand, const Mesh& target, const pyb::object& free, const pyb::kwargs& kw) {
        const Mask mask = mask_from(free, "free").value_or(Mask());
        const PlannerOptions o = planner_options(kw);
        pyb::gil_scoped_release release;
        return resolve_planner(hand, target, mask, o);
      },
      "hand"_a, "target"_a, "free"_a = pyb::none(),
      (std::string("The parameters a GraspPlanner would resolve (before indexing anything). ") + kPlannerOptionsDoc).c_str());

  pyb::class_<GraspPlanner>(
      m, "GraspPlanner",
      "Everything built once per hand and target: the resolved parameters, the target's unit facets and pair index, "
      "the aligner and the grasp checker (the C++ planning API; pairgrasp.Planner drives it).")
      .def(pyb::init([](const Hand& hand, const Mesh& target, const pyb::object& free, const pyb::object& obstacles,
                        const pyb::object& regions, const pyb::object& occluders, double occluder_distance,
                        const pyb::object& viewpoints, const pyb::object& support, const pyb::kwargs& kw) {
             Scene scene;
             scene.occlusion = occlusion_from(free, regions, occluders, occluder_distance, viewpoints, support);
             scene.obstacles = obstacles_from(obstacles);
             const PlannerOptions o = planner_options(kw);
             pyb::gil_scoped_release release;
             return std::make_unique<GraspPlanner>(hand, target, scene, o);
           }),
           "hand"_a, "target"_a, "free"_a = pyb::none(), "obstacles"_a = pyb::list(),
           "regions"_a = pyb::none(), "occluders"_a = pyb::none(), "occluder_distance"_a = 0.005,
           "viewpoints"_a = pyb::none(), "support"_a = pyb::none(),
           (std::string("The scene: `free` (per-face paint mask), `regions`, `occluders` (within `occluder_distance` m), "
           "`viewpoints` and `support` (SupportPlane) give the free surface (pairgrasp.free_surface at half the "
           "first unit-facet edge); `obstacles` and the support's box are what the hand must not touch. "
           + std::string(kPlannerOptionsDoc)).c_str()))
      .def_property_readonly("target", &GraspPlanner::target, pyb::return_value_policy::reference_internal,
                             "The target planned on: faces split where the free surface changes.")
      .def_property_readonly("free", [](const GraspPlanner& p) { return mask_to_numpy(p.free()); },
                             "(F,) bool per face of `target`, True = free.")
      .def_property_readonly("free_surface", &GraspPlanner::free_surface, pyb::return_value_policy::reference_internal)
      .def_property_readonly("obstacles", [](const GraspPlanner& p) {
            pyb::list out;
            for (const Obstacle& o : p.obstacles()) out.append(pyb::make_tuple(o.name, o.mesh));
            return out;
          }, "[(name, Mesh)]: what the hand is checked against (the scene's obstacles, then the support's box).")
      .def_property_readonly("setup", &GraspPlanner::setup, pyb::return_value_policy::reference_internal)
      .def_property_readonly("target_index", &GraspPlanner::target_index, pyb::return_value_policy::reference_internal)
      .def_property_readonly("aligner", &GraspPlanner::aligner, pyb::return_value_policy::reference_internal)
      .def_property_readonly("checker", &GraspPlanner::checker, pyb::return_value_policy::reference_internal)
      .def_property_readonly("reference", [](const GraspPlanner& p) {
            return pyb::make_tuple(Eigen::Vector3d(p.reference().center), p.reference().radius);
          }, "(torque origin (m), torque scale (m)) of epsilon.")
      .def_property_readonly("setup_seconds", &GraspPlanner::setup_seconds)
      .def("steps", &GraspPlanner::steps, "step"_a = 0.0,
           "Per-DOF step: `step` (rad) for angular DOFs (0: the hand's), the hand's for linear ones.")
      .def("constellation", [](const GraspPlanner& p, const pyb::object& dofs) {
            return p.constellation(vector_from(dofs, "dofs"));
          }, "dofs"_a, "The constellation aligned for a DOF sample.")
      .def(
          "align",
          [](const GraspPlanner& p, const pyb::object& samples) {
            const std::vector<Eigen::VectorXd> qs = samples_from(samples, static_cast<long>(p.hand().dofs().size()));
            std::vector<AlignResult> r;
            {
              pyb::gil_scoped_release release;
              r = p.align(qs);
            }
            pyb::list out;
            for (AlignResult& a : r) {
              pyb::list poses;
              for (AlignedPose& pose : a.poses) poses.append(pyb::cast(std::move(pose)));
              out.append(poses);
            }
            return out;
          },
          "samples"_a, "Aligns each sample (K, D): a list of K lists of AlignedPose, best first.")
      .def(
          "match_fractions",
          [](const GraspPlanner& p, const pyb::object& samples) {
            const std::vector<Eigen::VectorXd> qs = samples_from(samples, static_cast<long>(p.hand().dofs().size()));
            std::vector<double> r;
            {
              pyb::gil_scoped_release release;
              r = p.match_fractions(qs);
            }
            return r;
          },
          "samples"_a,
          "Early-rejection score of each sample (K, D): the fraction of its constellation's pairs that match a "
          "stored target pair within the aligner's feature tolerance.");

  m.def(
      "hull_rank_for",
      [](int top, int fine_tune, const std::string& rank, int rank_pool, const pyb::object& robust_pool) {
        FinishOptions o;
        o.top = top;
        o.fine_tune = fine_tune;
        o.rank = ranking_from_string(rank);
        o.rank_pool = rank_pool_arg(rank_pool, robust_pool);
        return hull_rank_for(o);
      },
      "top"_a, "fine_tune"_a, "rank"_a, "rank_pool"_a = FinishOptions().rank_pool, "robust_pool"_a = pyb::none(),
      "The CandidatePipeline hull_rank under which every grasp finish() can pick has its exact epsilon.");

  m.def(
      "_dof_axes",
      [](const pyb::object& lower, const pyb::object& upper, const pyb::object& step) {
        return dof_axes(vector_from(lower, "lower"), vector_from(upper, "upper"), vector_from(step, "step"));
      },
      "lower"_a, "upper"_a, "step"_a, "Per-DOF sample values (see pairgrasp.dof_grid).");

}

}  // namespace pairgrasp::py
