// Alignment: the six-pairing versor solver and the Aligner.
#include "bind.hpp"

#include <pairgrasp/aligner.hpp>
#include <pairgrasp/pair_index.hpp>
#include <pairgrasp/versor.hpp>

#include <algorithm>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace pairgrasp::py {

namespace {


Eigen::Matrix4d to_matrix(const Pose& p) { return p.matrix(); }


// An (N,3) float array (anything NumPy converts) as Points; `rows` < 0: any N. Throws
// std::invalid_argument (ValueError) naming the argument for anything else.
Points as_points(const pyb::handle& obj, const std::string& name, long rows = -1) {
  using Array = pyb::array_t<double, pyb::array::c_style | pyb::array::forcecast>;
  const std::string want = rows < 0 ? "(P, 3)" : "(" + std::to_string(rows) + ", 3)";
  Array a = Array::ensure(obj);
  if (!a) throw std::invalid_argument(name + ": expected a " + want + " float array");
  if (a.ndim() != 2 || a.shape(1) != 3 || (rows >= 0 && a.shape(0) != rows))
    throw std::invalid_argument(name + ": expected " + want + ", got " + shape_of(a));
  Points p(a.shape(0), 3);
  std::copy(a.data(), a.data() + a.size(), p.data());
  return p;
}

PairPoseOptions pair_pose_options(double angle_tolerance, double collinear_tolerance, int min_agreement) {
  PairPoseOptions o;
  o.angle_tolerance = angle_tolerance;
  o.collinear_tolerance = collinear_tolerance;
  o.min_agreement = min_agreement;
  return o;
}

PairPoseResult solve_arrays(const pyb::object& gp, const pyb::object& gn, const pyb::object& tp,
                            const pyb::object& tn, double angle_tolerance, double collinear_tolerance,
                            int min_agreement) {
  return solve_pair_pose(as_points(gp, "gripper_points", 2), as_points(gn, "gripper_normals", 2),
                         as_points(tp, "target_points", 2), as_points(tn, "target_normals", 2),
                         pair_pose_options(angle_tolerance, collinear_tolerance, min_agreement));
}

// One constellation's alignment by `align` (points, normals) without the GIL: the poses as a list,
// the whole result in `r`.
template <class Align>
pyb::list aligned(const pyb::object& points_in, const pyb::object& normals_in, AlignResult& r, Align align) {
  const Points points = as_points(points_in, "points");
  const Points normals = as_points(normals_in, "normals");
  {
    pyb::gil_scoped_release release;
    r = align(points, normals);
  }
  pyb::list poses;
  for (auto& p : r.poses) poses.append(pyb::cast(std::move(p)));
  return poses;
}

double optional_value(const pyb::object& v, const char* name) {
  if (v.is_none()) return 0.0;
  try {
    return v.cast<double>();
  } catch (const pyb::cast_error&) {
    throw std::invalid_argument(std::string(name) + ": expected a number or None");
  }
}

// (points, normals) from a Constellation, a (points, normals) tuple/list, or any object with
// `points` and `normals` attributes.
Constellation to_constellation(const pyb::handle& item, std::size_t k) {
  if (pyb::isinstance<Constellation>(item)) return item.cast<Constellation>();
  Constellation c;
  const std::string where = "constellations[" + std::to_string(k) + "]";
  try {
    if (pyb::isinstance<pyb::tuple>(item) || pyb::isinstance<pyb::list>(item)) {
      const auto seq = pyb::reinterpret_borrow<pyb::sequence>(item);
      if (seq.size() != 2)
        throw std::invalid_argument(where + ": expected (points, normals), got a sequence of " +
                                    std::to_string(seq.size()));
      c.points = as_points(seq[0], where + ": points");
      c.normals = as_points(seq[1], where + ": normals");
    } else if (pyb::hasattr(item, "points") && pyb::hasattr(item, "normals")) {
      c.points = as_points(item.attr("points"), where + ": points");
      c.normals = as_points(item.attr("normals"), where + ": normals");
    } else {
      throw std::invalid_argument(where + ": expected a Constellation or a (points, normals) tuple");
    }
  } catch (const pyb::error_already_set& e) {
    throw std::invalid_argument(where + ": " + e.what());
  }
  return c;
}

std::string stats_repr(const AlignStats& s) {
  std::ostringstream o;
  o << "AlignStats(gripper_pairs=" << s.gripper_pairs << ", collinear_pairs=" << s.collinear_pairs
    << ", correspondences=" << s.correspondences << ", correspondences_used=" << s.correspondences_used
    << ", prefiltered=" << s.prefiltered << ", candidates=" << s.candidates << ", rotation_votes=" << s.rotation_votes
    << ", dropped_rotation_votes=" << s.dropped_rotation_votes << ", rotation_bins=" << s.rotation_bins
    << ", position_votes=" << s.position_votes << ", dropped_position_votes=" << s.dropped_position_votes
    << ", position_bins=" << s.position_bins << ", saturated=" << (s.saturated ? "True" : "False") << ")";
  return o.str();
}

}  // namespace

void bind_alignment(pyb::module_& m) {
  using namespace pybind11::literals;

  pyb::enum_<PairPoseStatus>(m, "PairPoseStatus", "Why solve_pair_pose returned what it returned.")
      .value("ok", PairPoseStatus::Ok, "at least one candidate")
      .value("underdetermined", PairPoseStatus::Underdetermined,
             "one side's normals lie along its connecting line (antipodal pair): the roll is free")
      .value("no_agreement", PairPoseStatus::NoAgreement,
             "no rotation satisfies two pairings of either point order: not a rigid correspondence")
      .def("__str__", [](PairPoseStatus s) { return std::string(to_string(s)); });

  pyb::class_<PairPoseCandidate>(m, "PairPoseCandidate",
                                 "A rigid pose carrying the gripper pair onto the target pair: "
                                 "p_T = rotation @ p_G + translation.")
      .def_property_readonly(
          "rotation", [](pyb::object self) { return readonly_view(self.cast<const PairPoseCandidate&>().rotation, self); },
          "(3, 3) rotation, gripper (wrist) frame to target frame.")
      .def_property_readonly(
          "translation",
          [](pyb::object self) { return readonly_view(self.cast<const PairPoseCandidate&>().translation, self); },
          "(3,) translation, metres (t = P_T - R P_G of the pair midpoints).")
      .def_property_readonly("pose", [](const PairPoseCandidate& c) { return to_matrix(c.pose()); },
                             "(4, 4) homogeneous transform.")
      .def_property_readonly(
          "axis", [](pyb::object self) { return readonly_view(self.cast<const PairPoseCandidate&>().axis, self); },
          "(3,) canonical rotation axis (upper hemisphere).")
      .def_readonly("angle", &PairPoseCandidate::angle, "Rotation angle about `axis`, radians in (-pi, pi].")
      .def_property_readonly(
          "versor",
          [](const PairPoseCandidate& c) {
            return Eigen::Vector4d(c.versor.w(), c.versor.x(), c.versor.y(), c.versor.z());
          },
          "(4,) unit quaternion (w, x, y, z), w >= 0.")
      .def_readonly("agreement", &PairPoseCandidate::agreement,
                    "Meetings of its point order the rotation reproduces (0..3; 3 = all three pairings agree).")
      .def_readonly("order", &PairPoseCandidate::order, "0: G0<->T0, G1<->T1; 1: G0<->T1, G1<->T0.")
      .def_readonly("residual", &PairPoseCandidate::residual,
                    "Root mean square angle (radians) between R A and B over the satisfied pairings.")
      .def("__repr__", [](const PairPoseCandidate& c) {
        std::ostringstream o;
        o << "PairPoseCandidate(angle=" << c.angle << ", agreement=" << c.agreement << ", order=" << c.order
          << ", residual=" << c.residual << ")";
        return o.str();
      });

  const char* solve_doc = R"doc(
Rigid poses carrying a gripper pair of oriented points onto a target pair (six-pairing versor
solver, no SVD), best first.

gripper_points, gripper_normals, target_points, target_normals: (2, 3) arrays. Gripper normals are
given as stored on the gripper (pointing out of the finger surface); the solver uses -n. Returns a
list of PairPoseCandidate (rotation, translation, pose, agreement, order, ...). An underdetermined
correspondence (both normals along the connecting line: an antipodal pair whose roll is free) or a
non-rigid one returns an empty list; solve_pair_pose_status() says which.
)doc";
  m.def(
      "solve_pair_pose",
      [](const pyb::object& gp, const pyb::object& gn, const pyb::object& tp, const pyb::object& tn,
         double angle_tolerance, double collinear_tolerance, int min_agreement) {
        return solve_arrays(gp, gn, tp, tn, angle_tolerance, collinear_tolerance, min_agreement).candidates;
      },
      solve_doc, "gripper_points"_a, "gripper_normals"_a, "target_points"_a, "target_normals"_a,
      "angle_tolerance"_a = PairPoseOptions().angle_tolerance,
      "collinear_tolerance"_a = PairPoseOptions().collinear_tolerance,
      "min_agreement"_a = PairPoseOptions().min_agreement);
  m.def(
      "solve_pair_pose_status",
      [](const pyb::object& gp, const pyb::object& gn, const pyb::object& tp, const pyb::object& tn,
         double angle_tolerance, double collinear_tolerance, int min_agreement) {
        return solve_arrays(gp, gn, tp, tn, angle_tolerance, collinear_tolerance, min_agreement).status;
      },
      "The PairPoseStatus of solve_pair_pose with the same arguments (ok, underdetermined, no_agreement).",
      "gripper_points"_a, "gripper_normals"_a, "target_points"_a, "target_normals"_a,
      "angle_tolerance"_a = PairPoseOptions().angle_tolerance,
      "collinear_tolerance"_a = PairPoseOptions().collinear_tolerance,
      "min_agreement"_a = PairPoseOptions().min_agreement);
  m.def("versor_rotation", &versor_rotation, "(3, 3) rotation of `angle` radians about the unit `axis`.", "angle"_a,
        "axis"_a);

  pyb::class_<AlignedPose>(m, "AlignedPose",
                           "A pose of the gripper aligned with the target: p_T = rotation @ p_G + translation.")
      .def_property_readonly(
          "rotation", [](pyb::object self) { return readonly_view(self.cast<const AlignedPose&>().rotation, self); },
          "(3, 3) rotation, wrist frame to target frame.")
      .def_property_readonly(
          "translation", [](pyb::object self) { return readonly_view(self.cast<const AlignedPose&>().translation, self); },
          "(3,) translation, metres.")
      .def_property_readonly("pose", [](const AlignedPose& p) { return to_matrix(p.pose()); },
                             "(4, 4) homogeneous transform (the wrist pose in the target frame).")
      .def_readonly("votes", &AlignedPose::votes, "Sum of the agreement of the supporting candidates.")
      .def_readonly("quality", &AlignedPose::quality, "Q_A = votes / (1 + variance) (paper eq. 8).")
      .def_readonly("variance", &AlignedPose::variance,
                    "Dimensionless: mean |P_T - R P_G - t|^2 / h^2 + mean angle(R_k, R)^2 / angle_tolerance^2 "
                    "over the votes (vote-weighted), h = index.spacing.")
      .def_readonly("position_rms", &AlignedPose::position_rms, "Metres: rms of |P_T - R P_G - t| over the votes.")
      .def_readonly("angle_rms", &AlignedPose::angle_rms, "Radians: rms of angle(R_k, R) over the votes.")
      .def_readonly("correspondences", &AlignedPose::correspondences, "Supporting solver candidates.")
      .def_property_readonly(
          "contacts", [](pyb::object self) { return readonly_view(self.cast<const AlignedPose&>().contacts, self); },
          "(K, 2) int32: gripper sample index, target facet index (deduplicated, sorted).")
      .def("__repr__", [](const AlignedPose& p) {
        std::ostringstream o;
        o << "AlignedPose(votes=" << p.votes << ", quality=" << p.quality << ", variance=" << p.variance
          << ", contacts=" << p.contacts.rows() << ")";
        return o.str();
      });

  pyb::class_<AlignStats>(m, "AlignStats", "Counts from one alignment.")
      .def_readonly("gripper_pairs", &AlignStats::gripper_pairs)
      .def_readonly("collinear_pairs", &AlignStats::collinear_pairs,
                    "gripper pairs skipped as underdetermined (antipodal)")
      .def_readonly("correspondences", &AlignStats::correspondences, "target pairs found by the queries")
      .def_readonly("correspondences_used", &AlignStats::correspondences_used, "after thinning")
      .def_readonly("underdetermined", &AlignStats::underdetermined)
      .def_readonly("no_agreement", &AlignStats::no_agreement)
      .def_readonly("prefiltered", &AlignStats::prefiltered,
                    "of underdetermined and no_agreement, those rejected before the pose solve")
      .def_readonly("candidates", &AlignStats::candidates, "solver candidates that voted")
      .def_readonly("rotation_votes", &AlignStats::rotation_votes)
      .def_readonly("dropped_rotation_votes", &AlignStats::dropped_rotation_votes)
      .def_readonly("rotation_bins", &AlignStats::rotation_bins)
      .def_readonly("rotation_clusters", &AlignStats::rotation_clusters)
      .def_readonly("position_votes", &AlignStats::position_votes)
      .def_readonly("dropped_position_votes", &AlignStats::dropped_position_votes)
      .def_readonly("position_bins", &AlignStats::position_bins,
                    "most bins held by one rotation cluster's position accumulator (<= position_capacity)")
      .def_readonly("saturated", &AlignStats::saturated, "some votes or correspondences were dropped")
      .def("__repr__", &stats_repr);

  pyb::class_<Aligner>(m, "Aligner", R"doc(
Aligns gripper constellations with one target through its PairIndex (three Hough-like passes:
correspondences, rotation votes, position votes). Poses come best first by Q_A.

Aligner(index, tolerance=None, angle_tolerance=None, position_tolerance=None, ...): tolerances
left None are derived from the index spacing h: tolerance (d, phi, beta) = (0.5 h, 0.1, 0.1),
angle_tolerance = 4 degrees, position_tolerance = 0.5 h. capacity bounds the rotation bins
(a full accumulator drops new bins and reports `saturated`). prefilter=False solves every
correspondence (same results, slower): it exists only to measure the pre-filter's gain.
antipodal_cone (radians, None: 15 degrees) and antipodal_rolls are align_antipodal()'s.
)doc")
      .def(pyb::init([](const PairIndex& index, const pyb::object& tolerance, const pyb::object& angle_tolerance,
                        const pyb::object& position_tolerance, const pyb::object& collinear_tolerance,
                        std::size_t capacity, std::size_t position_capacity, std::size_t max_correspondences,
                        int rotation_clusters, int positions_per_rotation, int max_poses, int min_agreement,
                        int min_votes, int threads, bool prefilter, const pyb::object& antipodal_cone,
                        int antipodal_rolls) {
             AlignerOptions o;
             if (!tolerance.is_none()) {
               std::vector<double> tol;
               try {
                 tol = tolerance.cast<std::vector<double>>();
               } catch (const pyb::cast_error&) {
                 throw std::invalid_argument("tolerance: expected 3 numbers (d, phi, beta) or None");
               }
               if (tol.size() != 3)
                 throw std::invalid_argument("tolerance: expected 3 values (d, phi, beta), got " +
                                             std::to_string(tol.size()));
               o.feature_tolerance = Eigen::Vector3d(tol[0], tol[1], tol[2]);
               for (int k = 0; k < 3; ++k)
                 if (!(o.feature_tolerance[k] > 0))
                   throw std::invalid_argument("tolerance: expected positive values, got " + std::to_string(tol[k]));
             }
             o.angle_tolerance = optional_value(angle_tolerance, "angle_tolerance");
             o.position_tolerance = optional_value(position_tolerance, "position_tolerance");
             o.collinear_tolerance = optional_value(collinear_tolerance, "collinear_tolerance");
             o.capacity = capacity;
             o.position_capacity = position_capacity;
             o.max_correspondences = max_correspondences;
             o.rotation_clusters = rotation_clusters;
             o.positions_per_rotation = positions_per_rotation;
             o.max_poses = max_poses;
             o.min_agreement = min_agreement;
             o.min_votes = min_votes;
             o.threads = threads;
             o.prefilter = prefilter;
             o.antipodal_cone = optional_value(antipodal_cone, "antipodal_cone");
             o.antipodal_rolls = antipodal_rolls;
             // The PairIndex is a handle to shared, immutable data: the copy is O(1).
             return Aligner(index, o);
           }),
           "index"_a, "tolerance"_a = pyb::none(), "angle_tolerance"_a = pyb::none(),
           "position_tolerance"_a = pyb::none(), "collinear_tolerance"_a = pyb::none(),
           "capacity"_a = AlignerOptions().capacity, "position_capacity"_a = AlignerOptions().position_capacity,
           "max_correspondences"_a = AlignerOptions().max_correspondences,
           "rotation_clusters"_a = AlignerOptions().rotation_clusters,
           "positions_per_rotation"_a = AlignerOptions().positions_per_rotation,
           "max_poses"_a = AlignerOptions().max_poses, "min_agreement"_a = AlignerOptions().min_agreement,
           "min_votes"_a = AlignerOptions().min_votes, "threads"_a = AlignerOptions().threads,
           "prefilter"_a = AlignerOptions().prefilter, "antipodal_cone"_a = pyb::none(),
           "antipodal_rolls"_a = AlignerOptions().antipodal_rolls)
      .def(
          "align_antipodal",
          [](const Aligner& a, const pyb::object& points_in, const pyb::object& normals_in, bool return_stats)
              -> pyb::object {
            AlignResult r;
            pyb::list poses = aligned(points_in, normals_in, r, [&a](const Points& p, const Points& n) {
              return a.align_antipodal(p, n);
            });
            if (return_stats) return pyb::make_tuple(poses, pyb::cast(r.stats));
            return std::move(poses);
          },
          R"doc(
Aligns a parallel jaw: points (2, 3), its two pads' samples in the wrist frame (metres), normals
(2, 3) pointing out of the pads, towards each other. The target's antipodal pairs no wider than the
pads (both outward normals within antipodal_cone, default 15 degrees, of the pair's line) vote for
grasp lines; up to max_poses lines, best first, give antipodal_rolls poses each (the jaw centred on
the line at evenly spaced turns about it). Returns a list of AlignedPose, or (poses, AlignStats)
with return_stats=True. Releases the GIL.
)doc",
          "points"_a, "normals"_a, "return_stats"_a = false)
      .def(
          "align",
          [](const Aligner& a, const pyb::object& points_in, const pyb::object& normals_in,
             bool return_stats, bool return_times) -> pyb::object {
            AlignResult r;
            pyb::list poses = aligned(points_in, normals_in, r, [&a](const Points& p, const Points& n) {
              return a.align(p, n);
            });
            if (return_times) {
              pyb::dict t;
              t["query"] = r.times.query;
              t["prefilter"] = r.times.prefilter;
              t["solve"] = r.times.solve;
              t["rotation_votes"] = r.times.rotation_votes;
              t["positions"] = r.times.positions;
              if (return_stats) return pyb::make_tuple(poses, pyb::cast(r.stats), t);
              return pyb::make_tuple(poses, t);
            }
            if (return_stats) return pyb::make_tuple(poses, pyb::cast(r.stats));
            return std::move(poses);
          },
          R"doc(
Aligns one constellation: points (P, 3) in the wrist frame (metres) and normals (P, 3) as stored on
the gripper (pointing out of the finger surface). Returns a list of AlignedPose, best first, or
(poses, AlignStats) with return_stats=True. return_times=True appends a dict of the phases' wall
milliseconds (query, prefilter, solve, rotation_votes, positions; not deterministic). Releases the GIL.
)doc",
          "points"_a, "normals"_a, "return_stats"_a = false, "return_times"_a = false)
      .def(
          "align_many",
          [](const Aligner& a, const pyb::sequence& constellations, bool return_stats) {
            std::vector<Constellation> cs;
            cs.reserve(constellations.size());
            for (std::size_t k = 0; k < constellations.size(); ++k) cs.push_back(to_constellation(constellations[k], k));
            std::vector<AlignResult> rs;
            {
              pyb::gil_scoped_release release;
              rs = a.align_many(cs);
            }
            pyb::list out;
            for (auto& r : rs) {
              pyb::list poses;
              for (auto& p : r.poses) poses.append(pyb::cast(std::move(p)));
              if (return_stats)
                out.append(pyb::make_tuple(poses, pyb::cast(r.stats)));
              else
                out.append(poses);
            }
            return out;
          },
          R"doc(
Aligns many constellations on all `threads` workers (a list of Constellation objects or
(points, normals) tuples). Returns one pose list per constellation, in order, each equal to
align() of it (or (poses, AlignStats) tuples with return_stats=True). Releases the GIL.
)doc",
          "constellations"_a, "return_stats"_a = false)
      .def_property_readonly("tolerance", [](const Aligner& a) { return Eigen::Vector3d(a.options().feature_tolerance); },
                             "(3,) feature tolerance (d metres, phi, beta) in use.")
      .def_property_readonly("angle_tolerance", [](const Aligner& a) { return a.options().angle_tolerance; },
                             "Rotation tolerance in use, radians.")
      .def_property_readonly("position_tolerance", [](const Aligner& a) { return a.options().position_tolerance; },
                             "Position cluster radius in use, metres.")
      .def_property_readonly("collinear_tolerance", [](const Aligner& a) { return a.options().collinear_tolerance; })
      .def_property_readonly("capacity", [](const Aligner& a) { return a.options().capacity; })
      .def_property_readonly("max_poses", [](const Aligner& a) { return a.options().max_poses; })
      .def_property_readonly("threads", [](const Aligner& a) { return a.options().threads; })
      .def_property_readonly("prefilter", [](const Aligner& a) { return a.options().prefilter; })
      .def_property_readonly("index", [](const Aligner& a) { return a.index(); }, "The target's PairIndex.")
      .def("__repr__", [](const Aligner& a) {
        std::ostringstream o;
        const auto& t = a.options().feature_tolerance;
        o << "Aligner(" << a.index().size() << " pairs, tolerance=(" << t[0] << ", " << t[1] << ", " << t[2]
          << "), angle_tolerance=" << a.options().angle_tolerance
          << ", position_tolerance=" << a.options().position_tolerance << ")";
        return o.str();
      });
}

}  // namespace pairgrasp::py
