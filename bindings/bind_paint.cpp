// Paint: per-face free masks from paint files or regions (pairgrasp/paint.hpp).
#include "bind.hpp"

#include <pybind11/stl/filesystem.h>

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

}  // namespace

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
}

}  // namespace pairgrasp::py
