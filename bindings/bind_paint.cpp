// Paint and the free surface: paint files and regions (pairgrasp/paint.hpp), occluders, viewpoints
// and the support plane at patch resolution (pairgrasp/free_surface.hpp).
#include "bind.hpp"

#include <pybind11/stl/filesystem.h>

#include <pairgrasp/free_surface.hpp>
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/paint.hpp>

#include <cmath>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace pairgrasp::py {
namespace {

using Shape = PaintRegion::Shape;

Eigen::Vector3d vec3_from(const pyb::handle& h, const std::string& field) {
  std::vector<double> v;
  try {
    v = h.cast<std::vector<double>>();
  } catch (const pyb::cast_error&) {
    throw std::invalid_argument(field + ": expected 3 numbers");
  }
  if (v.size() != 3) throw std::invalid_argument(field + ": expected 3 numbers, got " + std::to_string(v.size()));
  return {v[0], v[1], v[2]};
}

double number_from(const pyb::handle& h, const std::string& field) {
  if (!pyb::isinstance<pyb::str>(h) && !pyb::isinstance<pyb::bool_>(h)) {
    try {
      return h.cast<double>();
    } catch (const pyb::cast_error&) {
    }
  }
  throw std::invalid_argument(field + ": expected a number");
}

bool mark_from(const pyb::handle& h, const std::string& field) {
  if (pyb::isinstance<pyb::bool_>(h)) return h.cast<bool>();
  if (pyb::isinstance<pyb::str>(h)) {
    const auto s = h.cast<std::string>();
    if (s == "free") return true;
    if (s == "occluded") return false;
    throw std::invalid_argument(field + ": expected \"free\" or \"occluded\", got \"" + s + "\"");
  }
  throw std::invalid_argument(field + ": expected \"free\", \"occluded\" or a bool");
}

// A region given as a dict in the paint-file form, e.g.
// {"shape": "sphere", "center": [0, 0, 0.1], "radius": 0.02, "mark": "occluded"}.
PaintRegion region_from_dict(const pyb::dict& d, const std::string& field) {
  auto get = [&](const char* key) -> pyb::handle {
    if (!d.contains(key)) throw std::invalid_argument(field + "." + key + ": missing");
    return d[key];
  };
  const pyb::handle shape_h = get("shape");
  if (!pyb::isinstance<pyb::str>(shape_h)) throw std::invalid_argument(field + ".shape: expected a string");
  const auto shape = shape_h.cast<std::string>();
  PaintRegion r;
  std::vector<std::string> keys;
  if (shape == "halfspace") {
    r.shape = Shape::halfspace;
    r.point = vec3_from(get("point"), field + ".point");
    r.normal = vec3_from(get("normal"), field + ".normal");
    keys = {"point", "normal"};
  } else if (shape == "box") {
    r.shape = Shape::box;
    r.min = vec3_from(get("min"), field + ".min");
    r.max = vec3_from(get("max"), field + ".max");
    keys = {"min", "max"};
  } else if (shape == "sphere") {
    r.shape = Shape::sphere;
    r.center = vec3_from(get("center"), field + ".center");
    r.radius = number_from(get("radius"), field + ".radius");
    keys = {"center", "radius"};
  } else if (shape == "cylinder") {
    r.shape = Shape::cylinder;
    r.start = vec3_from(get("start"), field + ".start");
    r.end = vec3_from(get("end"), field + ".end");
    r.radius = number_from(get("radius"), field + ".radius");
    keys = {"start", "end", "radius"};
  } else {
    throw std::invalid_argument(field + ".shape: unknown shape \"" + shape +
                                "\" (expected halfspace, box, sphere or cylinder)");
  }
  r.free = mark_from(get("mark"), field + ".mark");
  for (const auto& item : d) {
    const auto k = pyb::str(item.first).cast<std::string>();
    bool known = k == "shape" || k == "mark" || k == "comment";
    for (const auto& a : keys) known = known || k == a;
    if (!known) throw std::invalid_argument(field + "." + k + ": unknown key for a " + shape + " region");
  }
  // Field prefix in the messages of validate().
  try {
    r.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(field + "." + e.what());
  }
  return r;
}

std::vector<PaintRegion> regions_from(const pyb::iterable& regions) {
  std::vector<PaintRegion> out;
  std::size_t i = 0;
  for (const auto& h : regions) {
    const std::string field = "regions[" + std::to_string(i++) + "]";
    if (pyb::isinstance<PaintRegion>(h)) {
      out.push_back(h.cast<PaintRegion>());
    } else if (pyb::isinstance<pyb::dict>(h)) {
      out.push_back(region_from_dict(h.cast<pyb::dict>(), field));
    } else {
      throw std::invalid_argument(field + ": expected a PaintRegion or a dict");
    }
  }
  return out;
}

std::string region_repr(const PaintRegion& r) {
  auto v = [](const Eigen::Vector3d& x) {
    return "(" + pyb::repr(pyb::float_(x.x())).cast<std::string>() + ", " +
           pyb::repr(pyb::float_(x.y())).cast<std::string>() + ", " +
           pyb::repr(pyb::float_(x.z())).cast<std::string>() + ")";
  };
  const std::string mark = std::string("'") + (r.free ? "free" : "occluded") + "'";
  const std::string radius = pyb::repr(pyb::float_(r.radius)).cast<std::string>();
  switch (r.shape) {
    case Shape::halfspace: return "PaintRegion.halfspace(" + v(r.point) + ", " + v(r.normal) + ", " + mark + ")";
    case Shape::box: return "PaintRegion.box(" + v(r.min) + ", " + v(r.max) + ", " + mark + ")";
    case Shape::sphere: return "PaintRegion.sphere(" + v(r.center) + ", " + radius + ", " + mark + ")";
    case Shape::cylinder:
      return "PaintRegion.cylinder(" + v(r.start) + ", " + v(r.end) + ", " + radius + ", " + mark + ")";
  }
  return "PaintRegion(?)";
}

pyb::dict region_dict(const PaintRegion& r) {
  auto v = [](const Eigen::Vector3d& x) { return pyb::make_tuple(x.x(), x.y(), x.z()); };
  pyb::dict d;
  d["shape"] = to_string(r.shape);
  switch (r.shape) {
    case Shape::halfspace: d["point"] = v(r.point); d["normal"] = v(r.normal); break;
    case Shape::box: d["min"] = v(r.min); d["max"] = v(r.max); break;
    case Shape::sphere: d["center"] = v(r.center); d["radius"] = r.radius; break;
    case Shape::cylinder: d["start"] = v(r.start); d["end"] = v(r.end); d["radius"] = r.radius; break;
  }
  d["mark"] = r.free ? "free" : "occluded";
  return d;
}


SupportPlane support_from(const pyb::handle& h) {
  if (pyb::isinstance<SupportPlane>(h)) return h.cast<SupportPlane>();
  throw std::invalid_argument("support: expected a pairgrasp.SupportPlane or None");
}

}  // namespace

Occlusion occlusion_from(const pyb::handle& paint, const pyb::handle& regions, const pyb::handle& occluders,
                         double distance, const pyb::handle& viewpoints, const pyb::handle& support) {
  Occlusion o;
  o.paint = mask_from(paint, "paint").value_or(Mask());
  if (!regions.is_none()) o.regions = regions_from(regions.cast<pyb::iterable>());
  o.occluders = meshes_from(occluders, "occluders");
  o.distance = distance;
  if (!viewpoints.is_none()) o.viewpoints = points_from(viewpoints, "viewpoints");
  if (!support.is_none()) o.support = support_from(support);
  return o;
}

void bind_paint(pyb::module_& m) {
  using V3 = Eigen::Vector3d;

  pyb::class_<PaintRegion> region(m, "PaintRegion", R"doc(
A region of space marking every face whose centroid lies inside it as free or occluded.

Build one with PaintRegion.halfspace / box / sphere / cylinder (metres, mark "free" or
"occluded", or a bool: True = free). Regions given to apply_regions may also be dicts in the
paint-file form, e.g. {"shape": "sphere", "center": [0, 0, 0.1], "radius": 0.02, "mark": "occluded"}.
)doc");
  pyb::enum_<Shape>(region, "Shape")
      .value("halfspace", Shape::halfspace)
      .value("box", Shape::box)
      .value("sphere", Shape::sphere)
      .value("cylinder", Shape::cylinder);
  region
      .def_static(
          "halfspace",
          [](const V3& point, const V3& normal, const pyb::object& mark) {
            return PaintRegion::halfspace(point, normal, mark_from(mark, "mark"));
          },
          pyb::arg("point"), pyb::arg("normal"), pyb::arg("mark") = "occluded",
          "Points p with (p - point) . normal >= 0 (the side the non-zero normal points to).")
      .def_static(
          "box",
          [](const V3& min, const V3& max, const pyb::object& mark) {
            return PaintRegion::box(min, max, mark_from(mark, "mark"));
          },
          pyb::arg("min"), pyb::arg("max"), pyb::arg("mark") = "occluded",
          "Points with min <= p <= max on every axis (metres).")
      .def_static(
          "sphere",
          [](const V3& center, double radius, const pyb::object& mark) {
            return PaintRegion::sphere(center, radius, mark_from(mark, "mark"));
          },
          pyb::arg("center"), pyb::arg("radius"), pyb::arg("mark") = "occluded",
          "Points with |p - center| <= radius (metres, radius > 0).")
      .def_static(
          "cylinder",
          [](const V3& start, const V3& end, double radius, const pyb::object& mark) {
            return PaintRegion::cylinder(start, end, radius, mark_from(mark, "mark"));
          },
          pyb::arg("start"), pyb::arg("end"), pyb::arg("radius"), pyb::arg("mark") = "occluded",
          "Points within radius of the axis start-end whose projection falls between the ends.")
      .def_static(
          "from_dict", [](const pyb::dict& d) { return region_from_dict(d, "region"); }, pyb::arg("region"),
          "A region from its paint-file form (a dict with 'shape', its fields and 'mark').")
      .def_readonly("shape", &PaintRegion::shape)
      .def_property_readonly("free", [](const PaintRegion& r) { return r.free; }, "True when the region marks free.")
      .def_property_readonly("mark", [](const PaintRegion& r) { return r.free ? "free" : "occluded"; })
      .def("contains", &PaintRegion::contains, pyb::arg("point"), "Whether a point (metres) lies inside.")
      .def("to_dict", &region_dict, "The paint-file form of the region.")
      .def("__repr__", &region_repr);

  m.def(
      "apply_regions",
      [](const Mesh& mesh, const pyb::iterable& regions, const std::optional<Mask>& start) {
        const std::vector<PaintRegion> rs = regions_from(regions);
        pyb::gil_scoped_release release;
        return start ? apply_regions(mesh, rs, *start) : apply_regions(mesh, rs);
      },
      pyb::arg("mesh"), pyb::arg("regions"), pyb::arg("start") = pyb::none(),
      R"doc(Per-face free mask (F,) bool after applying regions in order to `start` (default: all free).

Each region (PaintRegion or paint-file dict) sets the mark of every face whose centroid it
contains; later regions override earlier ones. ValueError for a start of the wrong size or a bad
region. An all-occluded result is returned as is.)doc");

  m.def(
      "load_paint",
      [](const std::filesystem::path& path, const Mesh& mesh) { return load_paint(path.string(), mesh); },
      pyb::arg("path"), pyb::arg("mesh"), pyb::call_guard<pyb::gil_scoped_release>(),
      R"doc(Reads a paint file (str or os.PathLike; JSON, see models/README.md) for `mesh`: per-face
free mask, (F,) bool.

Raises pairgrasp.FileError naming the file and field for a bad file (format, version, face
count, index out of range, region fields), ValueError when the paint leaves no free face.)doc");

  m.def(
      "save_paint",
      [](const std::filesystem::path& path, const Mesh& mesh, const Mask& mask) {
        save_paint(path.string(), mesh, mask);
      },
      pyb::arg("path"), pyb::arg("mesh"), pyb::arg("mask"), pyb::call_guard<pyb::gil_scoped_release>(),
      R"doc(Writes a paint file that load_paint reads back as `mask` ((F,) bool, True = free).

The larger side becomes "default" and the faces of the smaller side are listed. ValueError for a
mask of the wrong size or with no free face, pairgrasp.FileError when the file cannot be written.)doc");

  // ---------------------------------------------------------------- the free surface
  pyb::class_<SupportPlane>(m, "SupportPlane",
                            "A plane the target rests on (a table): a point on it and its upward normal (metres).")
      .def(pyb::init([](const V3& point, const V3& normal) {
             SupportPlane s;
             s.point = point;
             s.normal = normal;
             s.validate();
             return s;
           }),
           pyb::arg("point") = V3::Zero().eval(), pyb::arg("normal") = V3::UnitZ().eval(),
           "ValueError ('support: ...') for a non-finite point or normal or a zero normal.")
      .def_static("below", &SupportPlane::below, pyb::arg("target"), pyb::arg("up") = V3::UnitZ().eval(),
                  "The plane through the target's lowest point along `up`, normal `up` (the default support).")
      .def_static("under", &SupportPlane::under, pyb::arg("target"), pyb::arg("obstacle"), pyb::arg("distance") = 0.005,
                  "The plane of a face of `obstacle` that `target` stands on (a table mesh): the obstacle wholly "
                  "below it, the target above it with its lowest point within `distance` m, the obstacle's extent "
                  "covering the target's; None when there is none (or the obstacle has over 5,000 faces).")
      .def_readonly("point", &SupportPlane::point)
      .def_readonly("normal", &SupportPlane::normal)
      .def("height", &SupportPlane::height, pyb::arg("point"), "Signed height of a point above the plane (m).")
      .def("__repr__", [](const SupportPlane& s) {
        return "SupportPlane(point=" + std::string(pyb::repr(pyb::cast(s.point).attr("tolist")())) +
               ", normal=" + std::string(pyb::repr(pyb::cast(s.normal).attr("tolist")())) + ")";
      });

  pyb::class_<FreeSurface>(m, "FreeSurface", "The target with its free surface at patch resolution.")
      .def_readonly("mesh", &FreeSurface::mesh, "The target, faces split (conforming) where a mark changes.")
      .def_property_readonly("free", [](const FreeSurface& f) { return mask_to_numpy(f.free); },
                             "(F,) bool per face of `mesh`, True = free.")
      .def_readonly("source_faces", &FreeSurface::source_faces, "(F,) the target face each face lies in.")
      .def_readonly("resolution", &FreeSurface::resolution, "Longest edge (m) of a patch a mark still divides.")
      .def_readonly("split_faces", &FreeSurface::split_faces, "Target faces that were split (0: mesh is the target).");

  m.def(
      "free_surface",
      [](const Mesh& target, const pyb::object& paint, const pyb::object& regions, const pyb::object& occluders,
         double distance, const pyb::object& viewpoints, const pyb::object& support, double resolution, int threads) {
        const Occlusion o = occlusion_from(paint, regions, occluders, distance, viewpoints, support);
        pyb::gil_scoped_release release;
        return free_surface(target, o, resolution, threads);
      },
      pyb::arg("target"), pyb::arg("paint") = pyb::none(), pyb::arg("regions") = pyb::none(),
      pyb::arg("occluders") = pyb::none(), pyb::arg("distance") = 0.005, pyb::arg("viewpoints") = pyb::none(),
      pyb::arg("support") = pyb::none(), pyb::arg("resolution") = std::numeric_limits<double>::infinity(),
      pyb::arg("threads") = 0,
      R"doc(The free surface of `target` at patch resolution (FreeSurface): faces split where a mark
changes, down to `resolution` metres (inf: whole faces).

Marks: `paint` ((F,) bool per face), `regions` (PaintRegion or paint-file dicts, applied in order
per point), `occluders` (meshes: a point within `distance` m of one, or inside a closed one, is
occluded), `viewpoints` ((V,3): only what one of them sees stays free), `support` (SupportPlane:
within `distance` of it is occluded). ValueError naming the field for bad input, a support plane
that cuts through the target, or when nothing is left free ('no free face left: ...').)doc");

  m.def(
      "occluded_by",
      [](const Mesh& mesh, const pyb::object& occluders, double distance, const pyb::object& free, int threads) {
        const std::vector<Mesh> occ = meshes_from(occluders, "occluders");
        const Mask start = mask_from(free, "free").value_or(Mask());
        pyb::gil_scoped_release release;
        return occluded_by(mesh, occ, distance, start, threads);
      },
      pyb::arg("mesh"), pyb::arg("occluders"), pyb::arg("distance"), pyb::arg("free") = pyb::none(),
      pyb::arg("threads") = 0,
      "Per-face free mask (F,) bool of `mesh`: faces with a point within `distance` (m) of an occluder mesh, or "
      "inside a closed one, are occluded (False); whole faces (free_surface() splits them). ANDed with `free` "
      "when given. ValueError when no face is left free ('no free face left: ...').");
  m.def(
      "visible_from",
      [](const Mesh& mesh, const pyb::object& viewpoints, const pyb::object& free, const pyb::object& occluders,
         int threads) {
        const Points eyes = points_from(viewpoints, "viewpoints");
        const std::vector<Mesh> occ = meshes_from(occluders, "occluders");
        const Mask start = mask_from(free, "free").value_or(Mask());
        pyb::gil_scoped_release release;
        return visible_from(mesh, eyes, start, occ, threads);
      },
      pyb::arg("mesh"), pyb::arg("viewpoints"), pyb::arg("free") = pyb::none(), pyb::arg("occluders") = pyb::list(),
      pyb::arg("threads") = 0,
      "Per-face free mask (F,) bool of `mesh`: a face is free when some viewpoint ((V,3) array) sees it -- "
      "front-facing and the segment from one of its sample points (centroid, and 80% towards each corner) to the "
      "viewpoint blocked by no other face and no occluder. ANDed with `free` when given. ValueError when no face "
      "is left free.");
  m.def(
      "combine_free",
      [](const pyb::object& a, const pyb::object& b) {
        const auto ma = mask_from(a, "a"), mb = mask_from(b, "b");
        if (!ma || !mb) throw std::invalid_argument("a, b: expected two boolean masks");
        return combine_free(*ma, *mb);
      },
      pyb::arg("a"), pyb::arg("b"), "AND of two free masks; ValueError when no face is left free.");

  m.def("support_box", &support_box, pyb::arg("support"), pyb::arg("target"), pyb::arg("margin"),
        "The support as an obstacle: a box (Mesh named 'support') whose top face lies on the plane, covering the "
        "target's footprint widened by `margin` m on every side, `margin` deep.");

  m.def(
      "read_paint",
      [](const std::filesystem::path& path, const Mesh& mesh) {
        const Paint p = read_paint(path.string(), mesh);
        return pyb::make_tuple(mask_to_numpy(p.faces), pyb::cast(p.regions));
      },
      pyb::arg("path"), pyb::arg("mesh"),
      "A paint file's marks, not yet applied: ((F,) bool face marks, [PaintRegion]) -- what free_surface() takes "
      "as `paint` and `regions`. pairgrasp.FileError as load_paint().");
}

}  // namespace pairgrasp::py
