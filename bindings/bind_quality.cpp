// Contact wrenches and grasp quality (Ferrari-Canny epsilon). The Python wrappers in
// pairgrasp/quality.py check argument types and build the GraspQuality dataclass.
#include "bind.hpp"

#include <pairgrasp/error.hpp>
#include <pairgrasp/quality.hpp>
#include <pairgrasp/wrenches.hpp>

#include <optional>
#include <string>

namespace pairgrasp::py {

namespace {

using namespace pybind11::literals;

/// The contact model from the Python keyword arguments (values are checked in C++).
ContactModel model_from(double mu, int edges, bool soft, std::optional<double> torsion, int soft_rings) {
  ContactModel m;
  m.mu = mu;
  m.edges = edges;
  m.soft = soft;
  m.torsion = torsion;
  m.soft_rings = soft_rings;
  return m;
}

/// Points, normals and centre of a grasp from Python objects.
struct Grasp {
  Points points, normals;
  Eigen::Vector3d center;
};

Grasp grasp_from(const pyb::object& points, const pyb::object& normals, const pyb::object& center) {
  Grasp g{points_from(points, "points"), points_from(normals, "normals"), Eigen::Vector3d::Zero()};
  const Eigen::VectorXd c = vector_from(center, "center");
  detail::check_size("center: values", 3, c.size());
  g.center = c;
  return g;
}

const char* const kModelDoc =
    "mu: Coulomb friction >= 0; edges: pyramid edges >= 3; soft: soft-finger contacts with torsional friction "
    "radius `torsion` (m) and `soft_rings` latitude rings.";

}  // namespace

void bind_quality(pyb::module_& m) {
  m.def(
      "contact_wrenches",
      [](const pyb::object& points, const pyb::object& normals, const pyb::object& center, double radius, double mu,
         int edges, bool soft, std::optional<double> torsion, int soft_rings) {
        const Grasp g = grasp_from(points, normals, center);
        const ContactModel model = model_from(mu, edges, soft, torsion, soft_rings);
        pyb::gil_scoped_release release;
        return wrench_matrix(g.points, g.normals, g.center, radius, model);
      },
      "points"_a, "normals"_a, "center"_a, "radius"_a, "mu"_a = ContactModel().mu, "edges"_a = ContactModel().edges,
      "soft"_a = ContactModel().soft,
      "torsion"_a = pyb::none(), "soft_rings"_a = 0,
      (std::string("(N*D, 6) contact wrenches [f; ((p - center) x f + m n) / radius] in C++, D per contact (the "
                   "pyramid edges, then the soft contacts' rings and poles); normals are the target's outward "
                   "normals. ") +
       kModelDoc)
          .c_str());

  m.def(
      "_contact_frames",
      [](const pyb::object& normals) {
        const Points n = points_from(normals, "normals");
        pyb::array_t<double> out({static_cast<pyb::ssize_t>(n.rows()), pyb::ssize_t{3}, pyb::ssize_t{3}});
        double* data = out.mutable_data();
        for (Eigen::Index i = 0; i < n.rows(); ++i) {
          const Eigen::Matrix3d f = contact_frame(n.row(i).transpose());
          for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) data[9 * i + 3 * r + c] = f(r, c);
        }
        return out;
      },
      "normals"_a, "(N, 3, 3) contact frames, rows t1, t2, n (see pairgrasp.contact_frames).");

  m.def(
      "_grasp_quality",
      [](const pyb::object& points, const pyb::object& normals, const pyb::object& center, double radius, double mu,
         int edges, bool soft, std::optional<double> torsion, int soft_rings, int max_hull_wrenches,
         bool open_volume, bool volume, double min_epsilon) {
        const Grasp g = grasp_from(points, normals, center);
        QualityOptions o;
        o.contact = model_from(mu, edges, soft, torsion, soft_rings);
        o.max_hull_wrenches = max_hull_wrenches;
        o.open_volume = open_volume;
        o.volume = volume;
        o.min_epsilon = min_epsilon;
        GraspQuality q;
        {
          pyb::gil_scoped_release release;
          q = grasp_quality(g.points, g.normals, g.center, radius, o);
        }
        return pyb::make_tuple(q.epsilon, q.volume, q.force_closure, q.n_contacts, q.n_wrenches, q.rank, q.reason,
                               q.volume_exact);
      },
      "points"_a, "normals"_a, "center"_a, "radius"_a, "mu"_a, "edges"_a, "soft"_a, "torsion"_a, "soft_rings"_a,
      "max_hull_wrenches"_a, "open_volume"_a, "volume"_a = true, "min_epsilon"_a = 0.0,
      "(epsilon, volume, force_closure, n_contacts, n_wrenches, rank, reason, volume_exact) of a grasp, computed "
      "in C++ with qhull (see pairgrasp.grasp_quality).");

  m.def(
      "_force_resistance",
      [](const pyb::object& points, const pyb::object& normals, const pyb::object& center, double radius, double mu,
         int edges, bool soft, std::optional<double> torsion, int soft_rings, const pyb::object& directions) {
        const Grasp g = grasp_from(points, normals, center);
        const ContactModel model = model_from(mu, edges, soft, torsion, soft_rings);
        const Points d = directions.is_none() ? load_directions() : points_from(directions, "directions");
        pyb::gil_scoped_release release;
        return Eigen::VectorXd(force_resistance(g.points, g.normals, g.center, radius, d, model));
      },
      "points"_a, "normals"_a, "center"_a, "radius"_a, "mu"_a, "edges"_a, "soft"_a, "torsion"_a, "soft_rings"_a,
      "directions"_a = pyb::none(),
      "(K,) largest pure force at the torque origin along each unit direction (None: load_directions()) in the "
      "grasp wrench space (see pairgrasp.force_resistance).");

  m.def("_load_directions", [] { return load_directions(); },
        "(6, 3) the six load directions of the physics check (see pairgrasp.LOAD_DIRECTIONS).");

  m.def(
      "_epsilon_upper_bound",
      [](const Eigen::Ref<const Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>>& wrenches) {
        const Wrenches w = wrenches;
        pyb::gil_scoped_release release;
        return epsilon_upper_bound(w);
      },
      "wrenches"_a, "Hull-free upper bound of the epsilon of a (W, 6) wrench set (see pairgrasp.epsilon_upper_bound).");
}

}  // namespace pairgrasp::py
