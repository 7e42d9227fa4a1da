// Surface: unit facets (tessellate, UnitFacets), the pair feature, PairIndex, count_pairs,
// suggest_edge, build_target_index. Arrays come back as read-only zero-copy NumPy views.
#include "bind.hpp"

#include <pairgrasp/error.hpp>
#include <pairgrasp/facets.hpp>
#include <pairgrasp/features.hpp>
#include <pairgrasp/graspable.hpp>
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/pair_index.hpp>

#include <cstdint>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace pairgrasp::py {
namespace {

using namespace pybind11::literals;



pyb::array as_array(const pyb::handle& obj, const std::string& name) {
  try {
    return pyb::module_::import("numpy").attr("asarray")(obj, "dtype"_a = "float64");
  } catch (const pyb::error_already_set&) {
    throw std::invalid_argument(name + ": expected an array of numbers");
  }
}

// An (N,3) array of numbers as Points.
Points as_points(const pyb::handle& obj, const std::string& name) {
  const pyb::array a = as_array(obj, name);
  if (a.ndim() != 2 || a.shape(1) != 3) throw std::invalid_argument(name + ": expected shape (N, 3), got " + shape_of(a));
  const auto c = pyb::array_t<double, pyb::array::c_style | pyb::array::forcecast>::ensure(a);
  Points p(c.shape(0), 3);
  std::copy(c.data(), c.data() + c.size(), p.data());
  return p;
}

Eigen::Vector3d as_vec3(const pyb::handle& obj, const std::string& name) {
  const pyb::array a = as_array(obj, name);
  if (a.ndim() != 1 || a.shape(0) != 3) throw std::invalid_argument(name + ": expected 3 values, got shape " + shape_of(a));
  const auto c = pyb::array_t<double, pyb::array::c_style | pyb::array::forcecast>::ensure(a);
  return Eigen::Vector3d(c.data()[0], c.data()[1], c.data()[2]);
}

// None: empty (all free). Otherwise a 1-D array of `n` booleans (or 0/1 integers).
Mask as_mask(const pyb::handle& obj, const std::string& name, long n) {
  if (obj.is_none()) return Mask();
  pyb::array a = pyb::module_::import("numpy").attr("asarray")(obj);
  if (a.ndim() != 1) throw std::invalid_argument(name + ": expected a 1-D mask, got shape " + shape_of(a));
  if (a.shape(0) != n)
    throw std::invalid_argument(name + ": expected " + std::to_string(n) + " values, got " + std::to_string(a.shape(0)));
  const char kind = a.dtype().kind();
  if (kind != 'b' && kind != 'i' && kind != 'u' && a.size() > 0)
    throw std::invalid_argument(name + ": expected booleans, got dtype " + pyb::str(a.dtype()).cast<std::string>());
  const auto c = pyb::array_t<std::int64_t, pyb::array::c_style | pyb::array::forcecast>::ensure(a);
  Mask m(n);
  for (long i = 0; i < n; ++i) {
    const std::int64_t v = c.data()[i];
    if (v != 0 && v != 1)
      throw std::invalid_argument(name + ": expected booleans or 0/1, got " + std::to_string(v) + " at " +
                                  std::to_string(i));
    m[i] = v != 0;
  }
  return m;
}

PairIndexOptions index_options(double d_max, std::size_t max_pairs, int threads) {
  PairIndexOptions o;
  o.d_max = d_max;
  o.max_pairs = max_pairs;
  o.threads = threads;
  return o;
}

pyb::array_t<std::int64_t> to_int64(const std::vector<std::uint32_t>& v) {
  pyb::array_t<std::int64_t> out(static_cast<pyb::ssize_t>(v.size()));
  std::int64_t* p = out.mutable_data();
  for (std::size_t k = 0; k < v.size(); ++k) p[k] = v[k];
  return out;
}

}  // namespace

void bind_surface(pyb::module_& m) {
  // ------------------------------------------------------------------ unit facets
  pyb::class_<UnitFacets>(m, "UnitFacets", R"doc(
A surface re-sampled into unit facets of about equal area (edge length `edge`, metres).
Row k of every array describes facet k. Arrays are read-only views owned by this object.
Made by tessellate().)doc")
      .def_property_readonly("points", [](pyb::object self) { return readonly_view(self.cast<const UnitFacets&>().points, self); },
                             "(N, 3) facet centres on the surface, metres.")
      .def_property_readonly("normals", [](pyb::object self) { return readonly_view(self.cast<const UnitFacets&>().normals, self); },
                             "(N, 3) unit outward normals (those of the source faces).")
      .def_property_readonly("areas", [](pyb::object self) { return readonly_view(self.cast<const UnitFacets&>().areas, self); },
                             "(N,) facet areas, m^2; they add up to the mesh area.")
      .def_property_readonly("face_ids", [](pyb::object self) { return readonly_view(self.cast<const UnitFacets&>().face_ids, self); },
                             "(N,) int32 index of the mesh face holding each centre.")
      .def_property_readonly("free", [](pyb::object self) { return readonly_view(self.cast<const UnitFacets&>().free, self); },
                             "(N,) bool: the facet is free (reachable), from its source face's paint.")
      .def_readonly("edge", &UnitFacets::edge, "The edge length h used, metres.")
      .def("__len__", [](const UnitFacets& u) { return u.points.rows(); })
      .def("__repr__", [](const UnitFacets& u) {
        std::ostringstream s;
        s << "UnitFacets(" << u.points.rows() << " facets, edge=" << u.edge << " m, " << u.free.count() << " free)";
        return s.str();
      });

  m.def(
      "tessellate",
      [](const Mesh& mesh, double edge, const pyb::object& free, long max_facets) {
        const Mask mask = as_mask(free, "free", long(mesh.faces.rows()));
        pyb::gil_scoped_release release;
        return tessellate(mesh, edge, mask, max_facets);
      },
      "mesh"_a, "edge"_a, "free"_a = pyb::none(), "max_facets"_a = 2'000'000, R"doc(
Re-tessellates `mesh` into unit facets about `edge` metres apart (each about (sqrt(3)/2) edge^2).

free: optional per-face mask (True = free); each facet inherits its source face's paint and never
spans free and occluded faces, sharp edges (normals more than 60 degrees apart) or thin walls.
The facet areas add up to the mesh area and have a coefficient of variation <= 0.3 on meshes
whose features are not much smaller than `edge`. Deterministic; runs without the GIL.
Raises ValueError for a non-positive edge, a mask of the wrong size, or more than `max_facets`
facets (the message names the smallest edge that fits).)doc");

  // ------------------------------------------------------------------ graspable faces
  pyb::class_<GraspableFaces>(m, "GraspableFaces",
                              "The free faces that may hold a contact of a force-closure grasp (graspable_faces).")
      .def_property_readonly("faces", [](const GraspableFaces& g) { return mask_to_numpy(g.faces); },
                             "(F,) bool per face: free and graspable.")
      .def_readonly("free", &GraspableFaces::free, "Free faces.")
      .def_readonly("graspable", &GraspableFaces::graspable, "Free faces that are graspable.")
      .def_readonly("widest_cone", &GraspableFaces::widest_cone,
                    "The widest cone (half angle, radians) that held the inward normals near a point found "
                    "ungraspable (0: none was).")
      .def_readonly("limit", &GraspableFaces::limit,
                    "Largest cone half angle (radians) for a point to be ungraspable: pi/2 - atan(mu) less the "
                    "binning margin.");
  m.def(
      "graspable_faces",
      [](const Mesh& mesh, double span, double mu, const pyb::object& free, int threads) {
        const Mask mask = as_mask(free, "free", long(mesh.faces.rows()));
        pyb::gil_scoped_release release;
        return graspable_faces(mesh, mask, span, mu, threads);
      },
      "mesh"_a, "span"_a, "mu"_a = 0.5, "free"_a = pyb::none(), "threads"_a = 0, R"doc(
Which free faces of `mesh` may hold a contact of a force-closure grasp whose contacts all lie within
`span` metres of each other, with friction coefficient `mu` (GraspableFaces).

A necessary condition: when every inward normal of the free surface within `span` of a point lies
within 90 degrees - atan(mu) of one direction, every force a contact there can push has a positive
component along it, so no force-closure grasp has a contact there. A face is left out only when that
holds at every point of it (normals binned on a cube map, a margin of about 2.6 degrees; see
graspable.hpp). The planner indexes only graspable faces (PlannerSetup.graspable_faces) and refuses a
target with none. Raises ValueError for a non-positive span, a negative mu or a mask of the wrong size.)doc");

  // ------------------------------------------------------------------ pair feature
  m.def(
      "pair_feature",
      [](const pyb::object& p_i, const pyb::object& n_i, const pyb::object& p_j, const pyb::object& n_j) -> pyb::object {
        const pyb::array a = as_array(p_i, "p_i");
        if (a.ndim() == 1)
          return pyb::cast(Eigen::Vector3d(pair_feature(as_vec3(p_i, "p_i"), as_vec3(n_i, "n_i"), as_vec3(p_j, "p_j"),
                                                        as_vec3(n_j, "n_j"))));
        const Points pi = as_points(p_i, "p_i"), ni = as_points(n_i, "n_i"), pj = as_points(p_j, "p_j"),
                     nj = as_points(n_j, "n_j");
        detail::check_size("n_i: rows", pi.rows(), ni.rows());
        detail::check_size("p_j: rows", pi.rows(), pj.rows());
        detail::check_size("n_j: rows", pi.rows(), nj.rows());
        Points out(pi.rows(), 3);
        for (Eigen::Index k = 0; k < pi.rows(); ++k)
          out.row(k) = pair_feature(pi.row(k).transpose(), ni.row(k).transpose(), pj.row(k).transpose(),
                                    nj.row(k).transpose())
                           .transpose();
        return pyb::cast(out);
      },
      "p_i"_a, "n_i"_a, "p_j"_a, "n_j"_a, R"doc(
The pair feature e = (d, phi, beta_ij + beta_ji) of oriented points (p_i, n_i), (p_j, n_j):
d = |p_i - p_j| (m), phi = n_i . n_j, beta_ij + beta_ji = (n_i - n_j) . (p_i - p_j) / d (0 when
d = 0). Symmetric in i and j. Takes (3,) vectors (returns (3,)) or (N, 3) rows (returns (N, 3)).
Normals must be unit length.)doc");

  // ------------------------------------------------------------------ pair index
  pyb::class_<PairIndex>(m, "PairIndex", R"doc(
All pairs i < j of a target's facets with d <= d_max (both free), their features
(d, phi, beta_ij + beta_ji) and a balanced AABB hierarchy for tolerance-box queries.

PairIndex(points, normals, d_max=0.2, free=None, max_pairs=100_000_000, threads=0,
          max_pairs_per_cell=0, cell=None)

points, normals: (N, 3) facet centres (m) and unit outward normals; free: optional (N,) mask.
The pairs are counted before anything is stored: over `max_pairs` raises ValueError
(BudgetError) naming the facet count that fits. max_pairs_per_cell > 0 thins the dense cells
(of size `cell`: d metres, n_i.n_j, beta; None: (h / 2, 0.1, 0.1)) of the feature space to about
that many pairs each, chosen by a hash of the pair; `weights` tells how many pairs each stored one
stands for. Built without the GIL, on `threads` threads
(0: all cores). `pairs` and `features` are read-only views in the tree's order.)doc")
      .def(pyb::init([](const pyb::object& points, const pyb::object& normals, double d_max, const pyb::object& free,
                        std::size_t max_pairs, int threads, long max_pairs_per_cell, const pyb::object& cell) {
             const Points p = as_points(points, "points");
             const Points n = as_points(normals, "normals");
             const Mask mask = as_mask(free, "free", long(p.rows()));
             PairIndexOptions o = index_options(d_max, max_pairs, threads);
             if (max_pairs_per_cell < 0)
               throw std::invalid_argument("max_pairs_per_cell: expected an integer >= 0 (0: every pair), got " +
                                           std::to_string(max_pairs_per_cell));
             o.max_pairs_per_cell = static_cast<std::size_t>(max_pairs_per_cell);
             if (!cell.is_none()) o.cell = as_vec3(cell, "cell");
             pyb::gil_scoped_release release;
             return PairIndex(p, n, mask, o);
           }),
           "points"_a, "normals"_a, "d_max"_a = 0.2, "free"_a = pyb::none(), "max_pairs"_a = 100'000'000,
           "threads"_a = 0, "max_pairs_per_cell"_a = 0, "cell"_a = pyb::none())
      .def_property_readonly("pairs", [](pyb::object self) { return readonly_view(self.cast<const PairIndex&>().pairs(), self); },
                             "(M, 2) int32 facet indices of the stored pairs, i < j.")
      .def_property_readonly("features",
                             [](pyb::object self) { return readonly_view(self.cast<const PairIndex&>().features(), self); },
                             "(M, 3) float32 features (d, phi, beta_ij + beta_ji) of the stored pairs.")
      .def_property_readonly("points", [](pyb::object self) { return readonly_view(self.cast<const PairIndex&>().points(), self); },
                             "(N, 3) facet centres, metres.")
      .def_property_readonly("normals", [](pyb::object self) { return readonly_view(self.cast<const PairIndex&>().normals(), self); },
                             "(N, 3) unit normals.")
      .def_property_readonly("free",
                             [](pyb::object self) -> pyb::object {
                               const PairIndex& s = self.cast<const PairIndex&>();
                               if (s.free().size() == 0) return pyb::none();
                               return readonly_view(s.free(), self);
                             },
                             "(N,) free mask, or None when every facet is free.")
      .def_property_readonly("d_max", &PairIndex::d_max, "Largest stored pair distance, metres.")
      .def_property_readonly("pairs_found", &PairIndex::pairs_found,
                             "Pairs with d <= d_max before thinning (len() without thinning): what max_pairs bounds.")
      .def_property_readonly(
          "weights",
          [](const PairIndex& s) {
            pyb::array_t<std::int64_t> out(static_cast<pyb::ssize_t>(s.size()));
            std::int64_t* o = out.mutable_data();
            for (std::size_t k = 0; k < s.size(); ++k) o[k] = s.weight(k);
            return out;
          },
          "(M,) int64: the pairs each stored pair stands for (1 without thinning; see max_pairs_per_cell).")
      .def_property_readonly("thin_cell", [](const PairIndex& s) -> pyb::object {
            if (s.max_pairs_per_cell() == 0) return pyb::none();
            const Eigen::Vector3d c = s.thin_cell();
            return pyb::make_tuple(c[0], c[1], c[2]);
          }, "The thinning's feature cell (d metres, n_i.n_j, beta), or None without thinning.")
      .def_property_readonly("max_pairs_per_cell", &PairIndex::max_pairs_per_cell, "The thinning's cap (0: none).")
      .def_property_readonly("spacing", &PairIndex::spacing,
                             "Median nearest-neighbour distance of the points, metres (about the facet edge).")
      .def_property_readonly("nbytes", &PairIndex::nbytes, "Bytes held by the index (pairs, features, tree, points).")
      .def_property_readonly("depth", &PairIndex::depth, "Depth of the hierarchy's leaves.")
      .def("__len__", &PairIndex::size)
      .def(
          "query",
          [](const PairIndex& s, const pyb::object& feature, const pyb::object& tolerance) {
            const Eigen::Vector3d c = as_vec3(feature, "feature"), t = as_vec3(tolerance, "tolerance");
            std::vector<std::uint32_t> out;
            {
              pyb::gil_scoped_release release;
              s.query(c, t, out);
            }
            return to_int64(out);
          },
          "feature"_a, "tolerance"_a, R"doc(
Indices (int64, into `pairs`) of every stored pair with |features[k] - feature| <= tolerance on
each of the 3 components, compared in double on the stored float32 values: exactly the set a
brute-force scan `np.all(np.abs(features - feature) <= tolerance, axis=1)` gives, in increasing
order (as np.flatnonzero of that mask).)doc")
      .def(
          "count",
          [](const PairIndex& s, const pyb::object& features, const pyb::object& tolerance) -> pyb::object {
            const Eigen::Vector3d t = as_vec3(tolerance, "tolerance");
            const pyb::array a = as_array(features, "feature");
            if (a.ndim() == 1) return pyb::int_(s.count(as_vec3(features, "feature"), t));
            const Points f = as_points(features, "feature");
            pyb::array_t<std::int64_t> out(static_cast<pyb::ssize_t>(f.rows()));
            std::int64_t* o = out.mutable_data();
            {
              pyb::gil_scoped_release release;
              for (Eigen::Index k = 0; k < f.rows(); ++k) o[k] = std::int64_t(s.count(f.row(k).transpose(), t));
            }
            return std::move(out);
          },
          "feature"_a, "tolerance"_a,
          "The number of pairs query() would return for one (3,) feature (an int), or for each row of an "
          "(Q, 3) array (an int64 array), without listing them.")
      .def("__repr__", [](const PairIndex& s) {
        std::ostringstream o;
        o << "PairIndex(" << s.size() << " pairs of " << s.points().rows() << " facets, d_max=" << s.d_max()
          << " m, " << s.nbytes() << " bytes)";
        return o.str();
      });

  m.def(
      "count_pairs",
      [](const pyb::object& points, double d_max, const pyb::object& free, int threads) {
        const Points p = as_points(points, "points");
        const Mask mask = as_mask(free, "free", long(p.rows()));
        pyb::gil_scoped_release release;
        return count_pairs(p, d_max, mask, threads);
      },
      "points"_a, "d_max"_a, "free"_a = pyb::none(), "threads"_a = 0,
      "The number of pairs PairIndex(points, ..., d_max, free) would store, counted on a grid.");

  m.def(
      "suggest_edge",
      [](const Mesh& mesh, double d_max, std::size_t max_pairs, const pyb::object& free, double min_edge) {
        const Mask mask = as_mask(free, "free", long(mesh.faces.rows()));
        pyb::gil_scoped_release release;
        return suggest_edge(mesh, d_max, max_pairs, mask, min_edge);
      },
      "mesh"_a, "d_max"_a = 0.2, "max_pairs"_a = 100'000'000, "free"_a = pyb::none(), "min_edge"_a = 0.0, R"doc(
The finest facet edge (metres, to a few per cent) whose tessellation stores no more than
`max_pairs` pairs with d <= d_max: estimated from the area, then checked by tessellating and
counting. A positive `min_edge` is the finest edge wanted: counted first and returned when its
pairs fit; the result is never finer.)doc");

  pyb::class_<TargetIndex>(m, "TargetIndex", "A target ready for alignment: its unit facets and their PairIndex.")
      .def_readonly("facets", &TargetIndex::facets)
      .def_readonly("index", &TargetIndex::index)
      .def("__repr__", [](const TargetIndex& t) {
        std::ostringstream o;
        o << "TargetIndex(" << t.facets.points.rows() << " facets, edge=" << t.facets.edge << " m, " << t.index.size()
          << " pairs)";
        return o.str();
      });

  m.def(
      "build_target_index",
      [](const Mesh& mesh, const pyb::object& edge, double d_max, const pyb::object& free, std::size_t max_pairs,
         int threads) {
        const double e = edge.is_none() ? 0.0 : edge.cast<double>();
        if (!edge.is_none() && !(e > 0.0))
          throw std::invalid_argument("edge: expected a positive length in metres or None, got " + std::to_string(e));
        const Mask mask = as_mask(free, "free", long(mesh.faces.rows()));
        pyb::gil_scoped_release release;
        return build_target_index(mesh, e, mask, index_options(d_max, max_pairs, threads));
      },
      "mesh"_a, "edge"_a = pyb::none(), "d_max"_a = 0.2, "free"_a = pyb::none(), "max_pairs"_a = 100'000'000,
      "threads"_a = 0, R"doc(
Tessellates `mesh` at `edge` (None: suggest_edge(mesh, d_max, max_pairs, free)) and indexes the
pairs of its free facets. Returns a TargetIndex (`.facets`, `.index`).)doc");
}

}  // namespace pairgrasp::py
