// Validation: SurfaceQuery, reachability masks (occluded_by, visible_from), GraspChecker
// (penetration pruning, closing onto contact, contacts).
#include "bind.hpp"

#include <pairgrasp/collision.hpp>
#include <pairgrasp/grasp.hpp>
#include <pairgrasp/reachability.hpp>
#include <pairgrasp/surface_query.hpp>

#include <pairgrasp/error.hpp>

#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace pairgrasp::py {

namespace {

using namespace pybind11::literals;



pyb::array_t<bool> mask_to_numpy(const Mask& m) {
  pyb::array_t<bool> a(m.size());
  std::copy(m.data(), m.data() + m.size(), a.mutable_data());
  return a;
}

std::vector<Mesh> meshes_from(const pyb::handle& obj, const std::string& name) {
  std::vector<Mesh> out;
  std::size_t i = 0;
  for (const pyb::handle item : obj) {
    try {
      out.push_back(item.cast<Mesh>());
    } catch (const pyb::cast_error&) {
      throw std::invalid_argument(name + "[" + std::to_string(i) + "]: expected a pairgrasp.Mesh");
    }
    ++i;
  }
  return out;
}

pyb::array_t<double> matrix_array(const Eigen::MatrixXd& m) {
  pyb::array_t<double> a({m.rows(), m.cols()});
  auto r = a.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < m.rows(); ++i)
    for (Eigen::Index j = 0; j < m.cols(); ++j) r(i, j) = m(i, j);
  return a;
}

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

std::optional<Mask> mask_from(const pyb::handle& obj, const std::string& name) {
  if (obj.is_none()) return std::nullopt;
  pyb::array a = pyb::module_::import("numpy").attr("asarray")(obj);
  if (a.ndim() != 1) throw std::invalid_argument(name + ": expected a 1-D boolean array, got shape " + shape_of(a));
  const std::string kind = pyb::str(a.dtype().attr("kind"));
  if (kind != "b") throw std::invalid_argument(name + ": expected a boolean array, got dtype " + std::string(pyb::str(a.dtype())));
  const auto b = pyb::array_t<bool, pyb::array::c_style | pyb::array::forcecast>::ensure(a);
  Mask m(b.shape(0));
  for (pyb::ssize_t i = 0; i < b.shape(0); ++i) m[i] = b.data()[i];
  return m;
}

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

void bind_validation(pyb::module_& m) {
  // ---------------------------------------------------------------- SurfaceQuery
  pyb::class_<SurfacePoints>(m, "SurfacePoints", "Closest surface points of a batch of query points (row k: point k).")
      .def_property_readonly("points", [](pyb::object self) { return readonly_view(self.cast<const SurfacePoints&>().points, self); },
                             "(N,3) closest points on the surface, metres.")
      .def_property_readonly("normals", [](pyb::object self) { return readonly_view(self.cast<const SurfacePoints&>().normals, self); },
                             "(N,3) unit outward normals of the faces holding them.")
      .def_property_readonly("faces", [](pyb::object self) { return readonly_view(self.cast<const SurfacePoints&>().faces, self); },
                             "(N,) face ids.")
      .def_property_readonly("distances", [](pyb::object self) { return readonly_view(self.cast<const SurfacePoints&>().distances, self); },
                             "(N,) unsigned distances, metres.")
      .def("__len__", [](const SurfacePoints& s) { return s.faces.size(); });

  pyb::class_<RayHits>(m, "RayHits", "First hits of a batch of rays (row k: ray k). No hit: face -1, t = inf.")
      .def_property_readonly("t", [](pyb::object self) { return readonly_view(self.cast<const RayHits&>().t, self); },
                             "(N,) distances along the normalised directions, metres (inf: no hit).")
      .def_property_readonly("points", [](pyb::object self) { return readonly_view(self.cast<const RayHits&>().points, self); },
                             "(N,3) hit points, metres.")
      .def_property_readonly("normals", [](pyb::object self) { return readonly_view(self.cast<const RayHits&>().normals, self); },
                             "(N,3) unit outward normals of the faces hit.")
      .def_property_readonly("faces", [](pyb::object self) { return readonly_view(self.cast<const RayHits&>().faces, self); },
                             "(N,) faces hit, -1 for none.")
      .def_property_readonly("hit", [](const RayHits& h) {
        pyb::array_t<bool> a(h.faces.size());
        for (Eigen::Index i = 0; i < h.faces.size(); ++i) a.mutable_data()[i] = h.faces[i] >= 0;
        return a;
      }, "(N,) whether each ray hit a face.")
      .def("__len__", [](const RayHits& h) { return h.faces.size(); });

  pyb::class_<SurfaceQuery>(m, "SurfaceQuery",
                            "Closest points, distances, inside tests and ray casts on a mesh through an AABB tree "
                            "(built once; queries release the GIL and use all cores).\n\n"
                            "inside / signed_distance need a closed mesh: the sign comes from the angle-weighted "
                            "pseudo-normal at the closest point, with ray-parity votes where that is "
                            "ill-conditioned. Points on the surface (within surface_tolerance) are inside with "
                            "signed distance 0.")
      .def(pyb::init([](const Mesh& mesh) {
             pyb::gil_scoped_release release;
             return SurfaceQuery(mesh);
           }),
           "mesh"_a)
      .def_property_readonly("mesh", &SurfaceQuery::mesh, "The mesh queried (a copy).")
      .def_property_readonly("closed", &SurfaceQuery::closed, "Whether inside / signed_distance are defined.")
      .def_property_readonly("surface_tolerance", &SurfaceQuery::surface_tolerance,
                             "Distance (m) below which a point counts as on the surface.")
      .def(
          "closest",
          [](const SurfaceQuery& q, const pyb::object& points, int threads) {
            const Points p = points_from(points, "points");
            pyb::gil_scoped_release release;
            return q.batch_closest(p, threads);
          },
          "points"_a, "threads"_a = 0,
          "Closest surface points of (N,3) points: SurfacePoints (points, normals, faces, distances).")
      .def(
          "distance",
          [](const SurfaceQuery& q, const pyb::object& points, int threads) {
            const Points p = points_from(points, "points");
            pyb::gil_scoped_release release;
            return q.batch_distance(p, threads);
          },
          "points"_a, "threads"_a = 0, "(N,) unsigned distances (m) of (N,3) points to the surface.")
      .def(
          "inside",
          [](const SurfaceQuery& q, const pyb::object& points, int threads) {
            const Points p = points_from(points, "points");
            Mask in;
            {
              pyb::gil_scoped_release release;
              in = q.batch_inside(p, threads);
            }
            return mask_to_numpy(in);
          },
          "points"_a, "threads"_a = 0,
          "(N,) bool: inside the closed mesh (surface included). ValueError for an open mesh.")
      .def(
          "signed_distance",
          [](const SurfaceQuery& q, const pyb::object& points, int threads) {
            const Points p = points_from(points, "points");
            pyb::gil_scoped_release release;
            return q.batch_signed_distance(p, threads);
          },
          "points"_a, "threads"_a = 0,
          "(N,) signed distances (m): negative inside, positive outside. ValueError for an open mesh.")
      .def(
          "ray_cast",
          [](const SurfaceQuery& q, const pyb::object& origins, const pyb::object& directions, double max_t,
             int threads) {
            const Points o = points_from(origins, "origins");
            const Points d = points_from(directions, "directions");
            pyb::gil_scoped_release release;
            return q.batch_ray_cast(o, d, threads, max_t);
          },
          "origins"_a, "directions"_a, "max_t"_a = std::numeric_limits<double>::infinity(), "threads"_a = 0,
          "First hits of rays origins[k] + t * directions[k] / |directions[k]|, 0 <= t <= max_t: RayHits.")
      .def(
          "ray_hits",
          [](const SurfaceQuery& q, const pyb::object& origin, const pyb::object& direction, double max_t) {
            const Eigen::VectorXd o = vector_from(origin, "origin"), d = vector_from(direction, "direction");
            detail::check_size("origin", 3, o.size());
            detail::check_size("direction", 3, d.size());
            std::vector<RayHit> hits;
            {
              pyb::gil_scoped_release release;
              hits = q.ray_hits(Eigen::Vector3d(o), Eigen::Vector3d(d), max_t);
            }
            Eigen::VectorXd t(hits.size());
            Eigen::VectorXi f(hits.size());
            for (std::size_t i = 0; i < hits.size(); ++i) {
              t[i] = hits[i].t;
              f[i] = hits[i].face;
            }
            return pyb::make_tuple(t, f);
          },
          "origin"_a, "direction"_a, "max_t"_a = std::numeric_limits<double>::infinity(),
          "Every hit of one ray, sorted: (t (H,) metres, faces (H,)).");

  // ---------------------------------------------------------------- reachability
  m.def(
      "occluded_by",
      [](const Mesh& mesh, const pyb::object& occluders, double distance, const pyb::object& free, int threads) {
        const std::vector<Mesh> occ = meshes_from(occluders, "occluders");
        const Mask start = mask_from(free, "free").value_or(Mask());
        Mask out;
        {
          pyb::gil_scoped_release release;
          out = occluded_by(mesh, occ, distance, start, threads);
        }
        return mask_to_numpy(out);
      },
      "mesh"_a, "occluders"_a, "distance"_a, "free"_a = pyb::none(), "threads"_a = 0,
      "Free mask (F,) bool of `mesh`: faces within `distance` (m) of an occluder mesh, or inside a closed "
      "one, are occluded (False). ANDed with `free` when given. ValueError when no face is left free "
      "('no free face left: ...').");
  m.def(
      "visible_from",
      [](const Mesh& mesh, const pyb::object& viewpoints, const pyb::object& free, const pyb::object& occluders,
         int threads) {
        const Points eyes = points_from(viewpoints, "viewpoints");
        const std::vector<Mesh> occ = meshes_from(occluders, "occluders");
        const Mask start = mask_from(free, "free").value_or(Mask());
        Mask out;
        {
          pyb::gil_scoped_release release;
          out = visible_from(mesh, eyes, start, occ, threads);
        }
        return mask_to_numpy(out);
      },
      "mesh"_a, "viewpoints"_a, "free"_a = pyb::none(), "occluders"_a = pyb::list(), "threads"_a = 0,
      "Free mask (F,) bool of `mesh`: a face is free when some viewpoint ((V,3) array) sees it -- front-facing "
      "and the segment from one of its sample points (centroid, and 80% towards each corner) to the viewpoint "
      "blocked by no other face and no occluder. ANDed with `free` when given. ValueError when no face is "
      "left free.");
  m.def(
      "combine_free",
      [](const pyb::object& a, const pyb::object& b) {
        const auto ma = mask_from(a, "a"), mb = mask_from(b, "b");
        if (!ma || !mb) throw std::invalid_argument("a, b: expected two boolean masks");
        return mask_to_numpy(combine_free(*ma, *mb));
      },
      "a"_a, "b"_a, "AND of two free masks; ValueError when no face is left free.");

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
      "exact path. field_cell (m): the fields' cell edge.")
      .def(pyb::init([](const Hand& hand, const Mesh& target, const pyb::object& free, const pyb::object& obstacles,
                        double depth_tolerance, double gap, double sample_spacing, double contact_spacing,
                        double contact_cell, int threads, bool use_distance_field, double field_cell) {
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
             pyb::gil_scoped_release release;
             return GraspChecker(hand, target, mask, obs, o);
           }),
           "hand"_a, "target"_a, "free"_a = pyb::none(), "obstacles"_a = pyb::list(),
           "depth_tolerance"_a = CheckOptions().depth_tolerance, "gap"_a = CheckOptions().contact_gap,
           "sample_spacing"_a = CheckOptions().sample_spacing, "contact_spacing"_a = CheckOptions().contact_spacing,
           "contact_cell"_a = CheckOptions().contact_cell, "threads"_a = CheckOptions().threads,
           "use_distance_field"_a = CheckOptions().use_distance_field, "field_cell"_a = CheckOptions().field_cell)
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
}

}  // namespace pairgrasp::py
