// Collision: GraspChecker (penetration pruning), closing onto contact and contacts.
#include "bind.hpp"

#include <pairgrasp/collision.hpp>
#include <pairgrasp/grasp.hpp>

#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace pairgrasp::py {

namespace {

using namespace pybind11::literals;

std::string repr_check(const CheckResult& r) {
  std::ostringstream s;
  s.precision(4);
  s << "CheckResult(pruned=" << (r.pruned ? "True" : "False") << ", collision=" << (r.collision ? "True" : "False")
    << ", depth=" << r.depth << ", touches_occluded=" << (r.touches_occluded ? "True" : "False");
  if (!r.reason.empty()) s << ", reason='" << r.reason << "'";
  s << ")";
  return s.str();
}

}  // namespace

// Obstacles: a list of Mesh (named by their source) or (name, Mesh) pairs, or a dict name -> Mesh.
std::vector<Obstacle> obstacles_from(const pyb::handle& obj) {
  std::vector<Obstacle> out;
  if (obj.is_none()) return out;
  auto one = [&](const pyb::handle& item, const std::string& where, const std::string* given_name) {
    Obstacle o;
    try {
      if (given_name) {
        o.name = *given_name;
        o.mesh = item.cast<Mesh>();
      } else if (pyb::isinstance<pyb::tuple>(item) || pyb::isinstance<pyb::list>(item)) {
        const pyb::sequence pair = pyb::reinterpret_borrow<pyb::sequence>(item);
        if (pair.size() != 2) throw pyb::cast_error();
        o.name = pair[0].cast<std::string>();
        o.mesh = pair[1].cast<Mesh>();
      } else {
        o.mesh = item.cast<Mesh>();
        o.name = o.mesh.source;
      }
    } catch (const pyb::cast_error&) {
      throw std::invalid_argument(where + ": expected a pairgrasp.Mesh or a (name, Mesh) pair");
    }
    out.push_back(std::move(o));
  };
  if (pyb::isinstance<pyb::dict>(obj)) {
    for (const auto& kv : pyb::reinterpret_borrow<pyb::dict>(obj)) {
      const std::string name = pyb::str(kv.first);
      one(kv.second, "obstacles['" + name + "']", &name);
    }
  } else {
    std::size_t i = 0;
    for (const pyb::handle item : obj) one(item, "obstacles[" + std::to_string(i++) + "]", nullptr);
  }
  return out;
}

void bind_collision(pyb::module_& m) {
  // ---------------------------------------------------------------- checks
  pyb::class_<LinkCheck>(m, "LinkCheck", "Check result of one hand link.")
      .def_readonly("link", &LinkCheck::link, "Link name.")
      .def_readonly("colliding", &LinkCheck::colliding, "Intersects or lies (partly) inside the target or an obstacle.")
      .def_readonly("depth", &LinkCheck::depth, "Deepest penetration of this link (m).")
      .def_readonly("touches_occluded", &LinkCheck::touches_occluded,
                    "Within the contact gap of (or intersecting) an occluded target face.")
      .def_readonly("colliding_with", &LinkCheck::with, "Names of what it collides with ('target', obstacle names).")
      .def("__repr__", [](const LinkCheck& l) {
        std::ostringstream s;
        s << "LinkCheck('" << l.link << "', colliding=" << (l.colliding ? "True" : "False") << ", depth=" << l.depth
          << ", touches_occluded=" << (l.touches_occluded ? "True" : "False") << ")";
        return s.str();
      });

  pyb::class_<CollisionPair>(m, "CollisionPair", "A hand link colliding with the target or an obstacle.")
      .def_readonly("link", &CollisionPair::link)
      .def_readonly("other", &CollisionPair::other, "'target' or the obstacle's name.")
      .def_readonly("obstacle", &CollisionPair::obstacle)
      .def_readonly("intersecting", &CollisionPair::intersecting, "FCL found intersecting triangles.")
      .def_readonly("inside", &CollisionPair::inside, "Samples of one lie strictly inside the other.")
      .def_readonly("depth", &CollisionPair::depth, "metres")
      .def("__repr__", [](const CollisionPair& p) {
        std::ostringstream s;
        s << "CollisionPair('" << p.link << "', '" << p.other << "', depth=" << p.depth
          << ", intersecting=" << (p.intersecting ? "True" : "False") << ", inside=" << (p.inside ? "True" : "False")
          << ")";
        return s.str();
      });

  pyb::class_<CheckResult>(m, "CheckResult", "Result of GraspChecker.check.")
      .def_readonly("collision", &CheckResult::collision, "Any link collides with anything (any depth).")
      .def_readonly("depth", &CheckResult::depth, "Largest depth over links, target and obstacles (m).")
      .def_readonly("target_depth", &CheckResult::target_depth, "Largest depth into the target (m).")
      .def_readonly("penetrating", &CheckResult::penetrating, "target_depth > depth_tolerance.")
      .def_readonly("obstacle_collision", &CheckResult::obstacle_collision)
      .def_readonly("touches_occluded", &CheckResult::touches_occluded)
      .def_readonly("pruned", &CheckResult::pruned, "penetrating or obstacle_collision or touches_occluded.")
      .def_readonly("reason", &CheckResult::reason, "Why it is pruned ('' when kept).")
      .def_readonly("links", &CheckResult::links, "List of LinkCheck, in Hand.links order.")
      .def_readonly("pairs", &CheckResult::pairs, "List of CollisionPair.")
      .def("__repr__", &repr_check);

  pyb::class_<CloseResult>(m, "CloseResult", "Result of GraspChecker.close.")
      .def_readonly("dofs", &CloseResult::dofs, "(D,) closed DOF values.")
      .def_readonly("directions", &CloseResult::directions, "(D,) closing direction used for each DOF (+1, -1, 0).")
      .def_property_readonly("reasons", [](const CloseResult& r) {
        std::vector<std::string> out;
        for (StopReason s : r.reasons) out.emplace_back(to_string(s));
        return out;
      }, "Why each DOF stopped: 'contact', 'limit', 'blocked' or 'fixed'.")
      .def_readonly("clearance", &CloseResult::clearance,
                    "(D,) distance (m) of each DOF's links to the target/obstacles where it stopped.")
      .def_readonly("start_penetrating", &CloseResult::start_penetrating)
      .def_readonly("start", &CloseResult::start, "CheckResult at the starting DOFs.")
      .def_readonly("check", &CloseResult::check, "CheckResult at the closed DOFs.")
      .def_readonly("iterations", &CloseResult::iterations, "Distance evaluations used.")
      .def("__repr__", [](const CloseResult& r) {
        std::ostringstream s;
        s << "CloseResult(dofs=[" << r.dofs.transpose() << "], reasons=[";
        for (std::size_t i = 0; i < r.reasons.size(); ++i) s << (i ? ", " : "") << "'" << to_string(r.reasons[i]) << "'";
        s << "], pruned=" << (r.check.pruned ? "True" : "False") << ")";
        return s.str();
      });

  pyb::class_<Contacts>(m, "Contacts", "Contacts of a grasp with the target's free faces (target frame).")
      .def_property_readonly("points", [](pyb::object self) { return readonly_view(self.cast<const Contacts&>().points, self); },
                             "(C,3) points of the hand's active surfaces, metres.")
      .def_property_readonly("target_points", [](pyb::object self) { return readonly_view(self.cast<const Contacts&>().target_points, self); },
                             "(C,3) closest target surface points, metres.")
      .def_property_readonly("normals", [](pyb::object self) { return readonly_view(self.cast<const Contacts&>().normals, self); },
                             "(C,3) unit outward target normals at those points.")
      .def_property_readonly("distances", [](pyb::object self) { return readonly_view(self.cast<const Contacts&>().distances, self); },
                             "(C,) signed gaps (m): > 0 apart, < 0 inside the target.")
      .def_property_readonly("faces", [](pyb::object self) { return readonly_view(self.cast<const Contacts&>().faces, self); },
                             "(C,) target faces.")
      .def_property_readonly("links", [](const Contacts& c) {
        pyb::array_t<int> a(static_cast<pyb::ssize_t>(c.links.size()));
        std::copy(c.links.begin(), c.links.end(), a.mutable_data());
        return a;
      }, "(C,) indices into Hand.links.")
      .def_readonly("link_names", &Contacts::link_names, "Link name of each contact.")
      .def_readonly("occluded_count", &Contacts::occluded_count, "Contacts found on occluded faces (not listed).")
      .def("__len__", [](const Contacts& c) { return c.points.rows(); })
      .def("__repr__", [](const Contacts& c) {
        return "Contacts(" + std::to_string(c.points.rows()) + " on free faces, " + std::to_string(c.occluded_count) +
               " on occluded faces)";
      });

  m.def(
      "estimate_field_bytes",
      [](const Mesh& target, const pyb::object& free, double depth_tolerance, double gap, double field_cell) {
        CheckOptions o;
        o.depth_tolerance = depth_tolerance;
        o.contact_gap = gap;
        o.field_cell = field_cell;
        return estimate_field_bytes(target, mask_from(free, "free").value_or(Mask()), o);
      },
      "target"_a, "free"_a = pyb::none(), "depth_tolerance"_a = CheckOptions().depth_tolerance,
      "gap"_a = CheckOptions().contact_gap, "field_cell"_a = CheckOptions().field_cell,
      "Estimated peak bytes of the distance fields a GraspChecker builds for the target and its occluded faces "
      "(microseconds, before building; the planner refuses a target over its max_field_bytes by it).");

  pyb::class_<GraspChecker>(
      m, "GraspChecker",
      "Penetration pruning, closing onto contact and contacts of a hand against a target (and obstacles).\n\n"
      "Poses are 4x4 wrist poses in the target frame (p_T = R p_G + t). Built once (FCL BVH models and "
      "dense surface samples); every query releases the GIL.\n\n"
      "free: (F,) bool mask of the target's faces (None: all free). obstacles: list of Mesh (named by "
      "their source), of (name, Mesh) pairs, or a dict name -> Mesh, in the target frame. "
      "depth_tolerance (m): penetration tolerated before pruning -- set it to about 0.25 h (h: unit-facet "
      "edge). gap (m): contact gap. sample_spacing (m): depth samples (0: depth_tolerance). "
      "contact_spacing (m): active-surface samples for contacts; contact_cell (m): contacts thinned to one "
      "per cube of this edge per link. threads: check_many's threads (0: all cores). use_distance_field: "
      "check through distance fields (the exact queries deciding wherever a field's error bound straddles a "
      "threshold, so every flag equals the exact path's; depths within (sqrt(3)/2) field_cell); False: the "
      "exact path. field_cell (m): the fields' cell edge. support: a SupportPlane the target stands on, which "
      "CandidatePipeline's settling lifts the hand out of (give it as an obstacle too: support_box).")
      .def(pyb::init([](const Hand& hand, const Mesh& target, const pyb::object& free, const pyb::object& obstacles,
                        double depth_tolerance, double gap, double sample_spacing, double contact_spacing,
                        double contact_cell, int threads, bool use_distance_field, double field_cell,
                        std::optional<SupportPlane> support) {
             const Mask mask = mask_from(free, "free").value_or(Mask());
             const std::vector<Obstacle> obs = obstacles_from(obstacles);
             CheckOptions o;
             o.depth_tolerance = depth_tolerance;
             o.contact_gap = gap;
             o.sample_spacing = sample_spacing;
             o.contact_spacing = contact_spacing;
             o.contact_cell = contact_cell;
             o.threads = threads;
             o.use_distance_field = use_distance_field;
             o.field_cell = field_cell;
             o.support = support;
             if (support) support->validate();
             pyb::gil_scoped_release release;
             return GraspChecker(hand, target, mask, obs, o);
           }),
           "hand"_a, "target"_a, "free"_a = pyb::none(), "obstacles"_a = pyb::list(),
           "depth_tolerance"_a = CheckOptions().depth_tolerance, "gap"_a = CheckOptions().contact_gap,
           "sample_spacing"_a = CheckOptions().sample_spacing, "contact_spacing"_a = CheckOptions().contact_spacing,
           "contact_cell"_a = CheckOptions().contact_cell, "threads"_a = CheckOptions().threads,
           "use_distance_field"_a = CheckOptions().use_distance_field, "field_cell"_a = CheckOptions().field_cell,
           "support"_a = pyb::none())
      .def_property_readonly("support", [](const GraspChecker& c) { return c.options().support; },
                             "The SupportPlane settling lifts the hand out of (None: none).")
      .def_property_readonly("hand", &GraspChecker::hand)
      .def_property_readonly("target", &GraspChecker::target)
      .def_property_readonly("free", [](const GraspChecker& c) { return mask_to_numpy(c.free()); },
                             "(F,) free mask of the target.")
      .def_property_readonly("obstacle_names", [](const GraspChecker& c) {
        std::vector<std::string> out;
        for (const auto& o : c.obstacles()) out.push_back(o.name);
        return out;
      })
      .def_property_readonly("depth_tolerance", [](const GraspChecker& c) { return c.options().depth_tolerance; })
      .def_property_readonly("gap", [](const GraspChecker& c) { return c.options().contact_gap; })
      .def_property_readonly("target_query", &GraspChecker::target_query, "SurfaceQuery of the target.")
      .def_property_readonly("link_sample_counts", &GraspChecker::link_sample_counts,
                             "Depth samples per link (Hand.links order).")
      .def_property_readonly("target_sample_count", &GraspChecker::target_sample_count)
      .def_property_readonly("use_distance_field", [](const GraspChecker& c) { return c.options().use_distance_field; })
      .def_property_readonly("distance_field_bytes", &GraspChecker::distance_field_bytes,
                             "Bytes held by the distance fields (0 without them).")
      .def_property_readonly("distance_field_seconds", &GraspChecker::distance_field_seconds,
                             "Seconds spent building the distance fields.")
      .def(
          "check",
          [](const GraspChecker& c, const pyb::object& wrist_pose, const pyb::object& dofs, bool exact_depth) {
            const Pose w = pose_from(wrist_pose, "wrist_pose");
            const Eigen::VectorXd q = vector_from(dofs, "dofs");
            pyb::gil_scoped_release release;
            return c.check(w, q, exact_depth);
          },
          "wrist_pose"_a, "dofs"_a, "exact_depth"_a = true,
          "Check one 4x4 wrist pose and DOF vector: CheckResult (exact_depth as check_many).")
      .def(
          "check_many",
          [](const GraspChecker& c, const pyb::object& poses, const pyb::object& dofs, int threads, bool exact_depth) {
            const DoubleArray P = as_double_array(poses, "poses");
            if (P.ndim() != 3 || P.shape(1) != 4 || P.shape(2) != 4)
              throw std::invalid_argument("poses: expected a (K, 4, 4) array, got shape " + shape_of(P));
            const DoubleArray Q = as_double_array(dofs, "dofs");
            const long D = static_cast<long>(c.hand().dofs().size());
            if (Q.ndim() != 2 || Q.shape(0) != P.shape(0) || Q.shape(1) != D)
              throw std::invalid_argument("dofs: expected a (" + std::to_string(P.shape(0)) + ", " + std::to_string(D) +
                                          ") array, got shape " + shape_of(Q));
            std::vector<Pose> wrists;
            std::vector<Eigen::VectorXd> qs;
            for (pyb::ssize_t k = 0; k < P.shape(0); ++k) {
              wrists.push_back(pose_from_data(P.data() + 16 * k, "poses[" + std::to_string(k) + "]"));
              qs.emplace_back(Eigen::Map<const Eigen::VectorXd>(Q.data() + D * k, D));
            }
            pyb::gil_scoped_release release;
            return c.check_many(wrists, qs, threads, exact_depth);
          },
          "poses"_a, "dofs"_a, "threads"_a = -1, "exact_depth"_a = true,
          "check() for every (poses[k], dofs[k]) -- poses (K,4,4), dofs (K,D) -- on `threads` threads (-1: the "
          "checker's setting; 0: all cores), GIL released. Same results as serial check() calls. With "
          "exact_depth=False the depth search of a link stops once it prunes the pose: flags and reasons are "
          "unchanged, a depth beyond the tolerance is a lower bound (faster, for searches).")
      .def(
          "close",
          [](const GraspChecker& c, const pyb::object& wrist_pose, const pyb::object& dofs, const pyb::object& directions,
             int max_iterations) {
            const Pose w = pose_from(wrist_pose, "wrist_pose");
            const Eigen::VectorXd q = vector_from(dofs, "dofs");
            CloseOptions o;
            o.max_iterations = max_iterations;
            if (!directions.is_none()) {
              const Eigen::VectorXd d = vector_from(directions, "directions");
              o.directions.resize(d.size());
              for (Eigen::Index i = 0; i < d.size(); ++i) {
                if (d[i] != -1.0 && d[i] != 0.0 && d[i] != 1.0)
                  throw std::invalid_argument("directions[" + std::to_string(i) + "]: expected -1, 0 or +1");
                o.directions[i] = static_cast<int>(d[i]);
              }
            }
            pyb::gil_scoped_release release;
            return close_fingers(c, w, q, o);
          },
          "wrist_pose"_a, "dofs"_a, "directions"_a = pyb::none(), "max_iterations"_a = CloseOptions().max_iterations,
          "Close each closing DOF from `dofs` until its active surface is within the gap of the target (or an "
          "obstacle) or it reaches its limit: CloseResult (dofs, reasons, clearance, check, ...). directions: "
          "per-DOF +1/-1/0 overriding closing_directions().")
      .def(
          "contacts",
          [](const GraspChecker& c, const pyb::object& wrist_pose, const pyb::object& dofs) {
            const Pose w = pose_from(wrist_pose, "wrist_pose");
            const Eigen::VectorXd q = vector_from(dofs, "dofs");
            pyb::gil_scoped_release release;
            return find_contacts(c, w, q);
          },
          "wrist_pose"_a, "dofs"_a,
          "Contacts: active-surface samples within the gap of the target's free faces, thinned to one per "
          "contact_cell per link: Contacts (points, normals, distances, links, link_names, ...).");

  m.def(
      "closing_directions",
      [](const Hand& hand, const pyb::object& dofs) {
        const Eigen::VectorXd q = vector_from(dofs, "dofs");
        return closing_directions(hand, q);
      },
      "hand"_a, "dofs"_a,
      "(D,) closing direction of each DOF at `dofs`: +1, -1, or 0 for DOFs that do not close the hand (the "
      "Barrett spread), from the motion of the active surfaces along their normals.");

  pyb::class_<ClosingPush>(m, "ClosingPush",
                           "How each closing DOF's push on the object is met, least over the closing DOFs, in [-1, 1].")
      .def_readonly("opposition", &ClosingPush::opposition,
                    "How squarely the contacts it does not move (and its own, cancelling) push back: 1 straight "
                    "back, 0 only friction, -1 nothing.")
      .def_readonly("drive", &ClosingPush::drive,
                    "Largest cosine between a contact's closing motion and its inward normal: 1 into the "
                    "surface, near 0 sliding along it.")
      .def("__repr__", [](const ClosingPush& p) {
        return "ClosingPush(opposition=" + std::to_string(p.opposition) + ", drive=" + std::to_string(p.drive) + ")";
      });
  m.def(
      "closing_push",
      [](const Hand& hand, const pyb::object& wrist_pose, const pyb::object& dofs, const Contacts& contacts) {
        const Pose w = pose_from(wrist_pose, "wrist_pose");
        const Eigen::VectorXd q = vector_from(dofs, "dofs");
        return closing_push(hand, w, q, contacts);
      },
      "hand"_a, "wrist_pose"_a, "dofs"_a, "contacts"_a,
      "ClosingPush (opposition, drive) of a grasp's contacts (GraspChecker.contacts(wrist_pose, dofs)) at "
      "(wrist_pose, dofs): how squarely each closing DOF pushes into the surface and is pushed back.");
  m.def(
      "_closing_friction",
      [](const Hand& hand, const pyb::object& wrist_pose, const pyb::object& dofs, const pyb::object& points,
         const pyb::object& normals, const std::vector<int>& links, const pyb::object& center, double mu_max, int edges,
         double tolerance) {
        const Pose w = pose_from(wrist_pose, "wrist_pose");
        const Eigen::VectorXd q = vector_from(dofs, "dofs");
        Contacts k;
        k.points = points_from(points, "points");
        k.normals = points_from(normals, "normals");
        k.links = links;
        const Eigen::VectorXd c = vector_from(center, "center");
        if (c.size() != 3) throw std::invalid_argument("center: expected 3 coordinates, got " + std::to_string(c.size()));
        ClosingFrictionOptions o;
        o.mu_max = mu_max, o.edges = edges, o.tolerance = tolerance;
        pyb::gil_scoped_release release;
        return closing_friction(hand, w, q, k, Eigen::Vector3d(c), o);
      },
      "hand"_a, "wrist_pose"_a, "dofs"_a, "points"_a, "normals"_a, "links"_a, "center"_a, "mu_max"_a, "edges"_a,
      "tolerance"_a, "closing_friction() of grasp.hpp (see pairgrasp.closing_friction; links index Hand.links).");
}

}  // namespace pairgrasp::py
