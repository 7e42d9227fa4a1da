// Surface queries: SurfaceQuery (closest points, signed distance, rays).
#include "bind.hpp"

#include <pairgrasp/error.hpp>
#include <pairgrasp/surface_query.hpp>

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace pairgrasp::py {

namespace {
using namespace pybind11::literals;
}  // namespace

std::vector<Mesh> meshes_from(const pyb::handle& obj, const std::string& name) {
  if (obj.is_none()) return {};
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

void bind_query(pyb::module_& m) {
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
}

}  // namespace pairgrasp::py
