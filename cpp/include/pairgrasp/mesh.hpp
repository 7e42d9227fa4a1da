#pragma once
/// @file mesh.hpp
/// Triangle meshes: loading (STL, OBJ, PLY, COLLADA through assimp), validation and clean-up.
#include <pairgrasp/types.hpp>

#include <string>

namespace pairgrasp {

/// What clean-up did to a mesh, counted so that callers can report it.
struct MeshCleanup {
  int welded_vertices = 0;       ///< vertices merged into an equal one (STL stores each triangle alone)
  int unused_vertices = 0;       ///< vertices referenced by no triangle, dropped
  int degenerate_faces = 0;      ///< zero-area triangles removed
  int duplicate_faces = 0;       ///< triangles with the same three vertices as an earlier one, removed
  int flipped_faces = 0;         ///< triangles turned to make the winding consistent and outward
};

/// A triangle mesh in metres with its measured properties.
///
/// Invariants after load_mesh() or make_mesh(): every vertex is finite, every index is in range,
/// no triangle is degenerate or duplicated, and on a closed mesh the winding is consistent and
/// outward (positive volume). Face order is that of the source with removed faces left out, so
/// per-face data (paint masks) refer to these faces.
struct Mesh {
  Points vertices;     ///< (V,3) metres
  Triangles faces;     ///< (F,3) indices into vertices, counter-clockwise seen from outside
  std::string source;  ///< file it was loaded from, or a name given by the caller

  bool closed = false;            ///< every edge is shared by exactly two faces, consistently wound
  double area = 0.0;              ///< total surface area, m^2
  double volume = 0.0;            ///< enclosed volume, m^3 (0 when not closed)
  Eigen::Vector3d center_of_mass = Eigen::Vector3d::Zero();  ///< of the solid when closed, else of the surface
  Eigen::AlignedBox3d bounds;     ///< axis-aligned bounding box, metres
  MeshCleanup cleanup;            ///< what validation changed

  /// Unit outward normal of face f.
  Eigen::Vector3d face_normal(int f) const;
  /// Area of face f, m^2.
  double face_area(int f) const;
};

/// Options for load_mesh().
struct MeshLoadOptions {
  double scale = 1.0;           ///< multiply coordinates by this (0.001 loads millimetres as metres)
  double weld_tolerance = 1e-9; ///< vertices closer than this (relative to the bounding-box diagonal) are welded
  bool orient = true;           ///< make the winding consistent and outward where the mesh is closed
};

/// Loads a mesh file and returns it validated and cleaned.
///
/// All meshes of the file's scene are merged with their node transforms applied. COLLADA files
/// keep their authored axes (assimp's Z-up to Y-up rotation is undone, as RViz does) and their
/// `<unit meter="...">` is honoured. Throws FileError (missing, unreadable, unsupported, empty,
/// NaN/inf vertices, out-of-range indices) naming the file; std::invalid_argument for a
/// non-positive or non-finite scale.
Mesh load_mesh(const std::string& path, const MeshLoadOptions& options = {});

/// Builds a mesh from arrays with the same validation and clean-up as load_mesh().
/// `name` is used in error messages. Throws std::invalid_argument for bad input.
Mesh make_mesh(const Points& vertices, const Triangles& faces, const std::string& name = "mesh",
               const MeshLoadOptions& options = {});

}  // namespace pairgrasp
