// Meshes (pairgrasp/mesh.hpp): Mesh with zero-copy read-only NumPy views, load_mesh, make_mesh.
#include "bind.hpp"

#include <pairgrasp/mesh.hpp>

#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>

namespace pairgrasp::py {
namespace {

using namespace pybind11::literals;



Points vertices_from(const pyb::object& obj) {
  pyb::array a = pyb::module_::import("numpy").attr("asarray")(obj, "dtype"_a = "float64");
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw std::invalid_argument("vertices: expected shape (N, 3), got " + shape_of(a));
  const auto c = pyb::array_t<double, pyb::array::c_style | pyb::array::forcecast>::ensure(a);
  Points v(c.shape(0), 3);
  std::copy(c.data(), c.data() + c.size(), v.data());
  return v;
}

Triangles faces_from(const pyb::object& obj, Eigen::Index n_vertices, const std::string& name) {
  pyb::array a = pyb::module_::import("numpy").attr("asarray")(obj);
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw std::invalid_argument("faces: expected shape (F, 3), got " + shape_of(a));
  const char kind = a.dtype().kind();
  if (a.size() > 0 && kind != 'i' && kind != 'u')
    throw std::invalid_argument("faces: expected integer indices, got dtype " +
                                pyb::str(a.dtype()).cast<std::string>());
  if (kind == 'u' && a.size() > 0 && a.attr("max")().cast<unsigned long long>() >= (1ull << 62))
    throw std::invalid_argument("faces: index out of range [0, " + std::to_string(n_vertices) + ") (mesh '" +
                                name + "')");
  const auto c = pyb::array_t<std::int64_t, pyb::array::c_style | pyb::array::forcecast>::ensure(a);
  Triangles f(c.shape(0), 3);
  const std::int64_t* p = c.data();
  for (Eigen::Index i = 0; i < f.rows(); ++i)
    for (int k = 0; k < 3; ++k) {
      const std::int64_t x = p[3 * i + k];
      if (x < 0 || x >= n_vertices)  // before narrowing to 32 bits, so nothing wraps
        throw std::invalid_argument("faces: face " + std::to_string(i) + " has index " + std::to_string(x) +
                                    " out of range [0, " + std::to_string(n_vertices) + ") (mesh '" + name + "')");
      f(i, k) = static_cast<std::int32_t>(x);
    }
  return f;
}

MeshLoadOptions options_from(double scale, double weld_tolerance, bool orient) {
  MeshLoadOptions o;
  o.scale = scale;
  o.weld_tolerance = weld_tolerance;
  o.orient = orient;
  return o;
}

std::string repr_cleanup(const MeshCleanup& c) {
  std::ostringstream s;
  s << "MeshCleanup(welded_vertices=" << c.welded_vertices << ", unused_vertices=" << c.unused_vertices
    << ", degenerate_faces=" << c.degenerate_faces << ", duplicate_faces=" << c.duplicate_faces
    << ", flipped_faces=" << c.flipped_faces << ")";
  return s.str();
}

}  // namespace

void bind_mesh(pyb::module_& m) {
  pyb::class_<MeshCleanup>(m, "MeshCleanup",
                           "What clean-up did to a mesh: counts of welded and unused vertices, degenerate, "
                           "duplicate and flipped faces.")
      .def_readonly("welded_vertices", &MeshCleanup::welded_vertices,
                    "Vertices merged into an equal earlier one (STL stores each triangle alone).")
      .def_readonly("unused_vertices", &MeshCleanup::unused_vertices, "Vertices used by no remaining triangle.")
      .def_readonly("degenerate_faces", &MeshCleanup::degenerate_faces,
                    "Zero-area triangles removed (repeated index or collinear corners).")
      .def_readonly("duplicate_faces", &MeshCleanup::duplicate_faces,
                    "Triangles with the same three vertices as an earlier one, in any order, removed.")
      .def_readonly("flipped_faces", &MeshCleanup::flipped_faces,
                    "Triangles turned to make the winding consistent and outward.")
      .def("as_dict",
           [](const MeshCleanup& c) {
             return pyb::dict("welded_vertices"_a = c.welded_vertices, "unused_vertices"_a = c.unused_vertices,
                              "degenerate_faces"_a = c.degenerate_faces, "duplicate_faces"_a = c.duplicate_faces,
                              "flipped_faces"_a = c.flipped_faces);
           },
           "The counts as a dict.")
      .def("__eq__",
           [](const MeshCleanup& a, const MeshCleanup& b) {
             return a.welded_vertices == b.welded_vertices && a.unused_vertices == b.unused_vertices &&
                    a.degenerate_faces == b.degenerate_faces && a.duplicate_faces == b.duplicate_faces &&
                    a.flipped_faces == b.flipped_faces;
           },
           pyb::is_operator())
      .def("__repr__", &repr_cleanup);

  pyb::class_<Mesh>(m, "Mesh",
                    "A validated triangle mesh in metres (see load_mesh, make_mesh).\n\n"
                    "vertices (V,3) float64 and faces (F,3) int32 are read-only NumPy views of the mesh's own "
                    "buffers (no copy); a view keeps the mesh alive. Faces are counter-clockwise seen from "
                    "outside on closed parts; open parts keep the winding of the majority of their source "
                    "faces.")
      .def_property_readonly(
          "vertices", [](const pyb::object& self) { return readonly_view(self.cast<const Mesh&>().vertices, self); },
          "(V,3) float64 vertex positions, metres (read-only view).")
      .def_property_readonly(
          "faces", [](const pyb::object& self) { return readonly_view(self.cast<const Mesh&>().faces, self); },
          "(F,3) int32 vertex indices per triangle (read-only view).")
      .def_readonly("source", &Mesh::source, "The file it was loaded from, or the name given to make_mesh.")
      .def_readonly("closed", &Mesh::closed,
                    "Every edge is shared by exactly two faces that traverse it in opposite directions.")
      .def_readonly("area", &Mesh::area, "Surface area, m^2.")
      .def_readonly("volume", &Mesh::volume, "Enclosed volume, m^3; 0 when the mesh is not closed.")
      .def_property_readonly(
          "center_of_mass", [](const Mesh& mesh) { return Eigen::Vector3d(mesh.center_of_mass); },
          "(3,) centre of mass of the solid (uniform density) when closed, else the area-weighted centroid "
          "of the surface, metres.")
      .def_property_readonly(
          "bounds",
          [](const Mesh& mesh) {
            Eigen::Matrix<double, 2, 3, Eigen::RowMajor> b;
            b.row(0) = mesh.bounds.min().transpose();
            b.row(1) = mesh.bounds.max().transpose();
            return b;
          },
          "(2,3) axis-aligned bounding box: row 0 the minimum corner, row 1 the maximum, metres.")
      .def_readonly("boundary_edges", &Mesh::boundary_edges, "Edges used by one face only.")
      .def_readonly("non_manifold_edges", &Mesh::non_manifold_edges, "Edges used by more than two faces.")
      .def_readonly("cleanup", &Mesh::cleanup, "What validation changed (MeshCleanup).")
      .def("face_normals", &Mesh::face_normals, "(F,3) unit outward normals of the faces.")
      .def(
          "face_areas",
          [](const Mesh& mesh) {
            Eigen::VectorXd a(mesh.faces.rows());
            for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) a[f] = mesh.face_area(static_cast<int>(f));
            return a;
          },
          "(F,) face areas, m^2.")
      .def("__repr__", [](const Mesh& mesh) {
        std::ostringstream s;
        s.precision(6);
        s << "<pairgrasp.Mesh '" << mesh.source << "': " << mesh.vertices.rows() << " vertices, " << mesh.faces.rows()
          << " faces, " << (mesh.closed ? "closed" : "open") << ", area " << mesh.area << " m^2, volume "
          << mesh.volume << " m^3, extent " << mesh.bounds.sizes().x() << " x " << mesh.bounds.sizes().y()
          << " x " << mesh.bounds.sizes().z() << " m>";
        return s.str();
      });

  m.def(
      "load_mesh",
      [](const pyb::object& path, double scale, double weld_tolerance, bool orient) {
        const std::string p = pyb::module_::import("os").attr("fsdecode")(path).cast<std::string>();
        const MeshLoadOptions o = options_from(scale, weld_tolerance, orient);
        pyb::gil_scoped_release release;
        return load_mesh(p, o);
      },
      "path"_a, "scale"_a = 1.0, "weld_tolerance"_a = MeshLoadOptions{}.weld_tolerance, "orient"_a = true,
      "Load a mesh file (STL, OBJ, PLY, COLLADA, ... through assimp), validated and cleaned.\n\n"
      "path: str or os.PathLike. scale multiplies coordinates (0.001 loads millimetres as metres). COLLADA "
      "keeps its authored axes (no Z-up to Y-up turn) and its <unit meter> is applied. Vertices closer than "
      "weld_tolerance times the bounding-box diagonal are welded; orient makes the winding consistent and "
      "outward.\nRaises pairgrasp.FileError (missing, unreadable, malformed, no triangles, NaN vertices, bad "
      "indices) naming the file, ValueError for a bad scale or tolerance.");

  m.def(
      "make_mesh",
      [](const pyb::object& vertices, const pyb::object& faces, const std::string& name, double scale,
         double weld_tolerance, bool orient) {
        Points v = vertices_from(vertices);
        Triangles f = faces_from(faces, v.rows(), name);
        const MeshLoadOptions o = options_from(scale, weld_tolerance, orient);
        pyb::gil_scoped_release release;
        return make_mesh(v, f, name, o);
      },
      "vertices"_a, "faces"_a, "name"_a = "mesh", "scale"_a = 1.0,
      "weld_tolerance"_a = MeshLoadOptions{}.weld_tolerance, "orient"_a = true,
      "Build a mesh from a (V,3) array of vertices (metres) and an (F,3) integer array of triangles, with the "
      "same validation and clean-up as load_mesh. Raises ValueError naming the argument (non-finite vertex, "
      "index out of range, wrong shape, no triangles).");
}

}  // namespace pairgrasp::py
