#pragma once
/// @file mesh.hpp
/// Triangle meshes: loading (STL, OBJ, PLY, COLLADA through assimp), validation and clean-up.
#include <pairgrasp/types.hpp>

#include <string>

namespace pairgrasp {

/// What clean-up did to a mesh, counted so that callers can report it.
///
/// For the vertices: input count = output count + welded_vertices + unused_vertices.
/// For the faces: input count = output count + degenerate_faces + duplicate_faces.
struct MeshCleanup {
  int welded_vertices = 0;       ///< vertices merged into an equal one (STL stores each triangle alone)
  int unused_vertices = 0;       ///< vertices referenced by no (remaining) triangle, dropped
  int degenerate_faces = 0;      ///< zero-area triangles removed (repeated index or collinear corners)
  int duplicate_faces = 0;       ///< triangles with the same three vertices as an earlier one (any order), removed
  int flipped_faces = 0;         ///< triangles turned to make the winding consistent and outward
};

/// A triangle mesh in metres with its measured properties.
///
/// Invariants after load_mesh() or make_mesh(): every vertex is finite, every index is in range,
/// no triangle is degenerate or duplicated, and every vertex is used by a triangle.
/// Face order is that of the source with removed faces left out, so per-face data (paint masks)
/// refer to these faces; vertices keep their source order with welded and unused ones left out.
///
/// Orientation (unless MeshLoadOptions::orient is false). Faces are grouped into components
/// connected through edges shared by exactly two faces; within a component the winding is made
/// consistent (the two faces of a shared edge traverse it in opposite directions).
/// - A closed component (every edge shared with exactly one other face of it) is turned so that
///   its normals point out of the solid: positive signed volume, or negative when the component
///   lies wholly inside an odd number of other closed components (the inner wall of a hollow
///   solid, whose normals point into the cavity).
/// - An open or non-manifold component has no inside: it keeps the orientation of the majority
///   of its source faces (on a tie, that of its first face). "Outward" there means "as authored".
struct Mesh {
  Points vertices;     ///< (V,3) metres
  Triangles faces;     ///< (F,3) indices into vertices, counter-clockwise seen from outside
  std::string source;  ///< file it was loaded from, or a name given by the caller

  /// Every edge is shared by exactly two faces that traverse it in opposite directions, and the
  /// surface encloses a volume (a closed surface that is flat, or whose parts' volumes cancel,
  /// has no inside and counts as open).
  bool closed = false;
  double area = 0.0;              ///< total surface area, m^2
  /// Enclosed volume, m^3: 0 when not closed; signed by the winding, so negative only for an
  /// inside-out closed mesh built with MeshLoadOptions::orient false.
  double volume = 0.0;
  /// Centre of mass of the solid (uniform density) when closed, else the area-weighted
  /// centroid of the surface; metres.
  Eigen::Vector3d center_of_mass = Eigen::Vector3d::Zero();
  Eigen::AlignedBox3d bounds;     ///< axis-aligned bounding box, metres
  int boundary_edges = 0;         ///< edges used by one face only (holes, open borders)
  int non_manifold_edges = 0;     ///< edges used by more than two faces
  MeshCleanup cleanup;            ///< what validation changed

  /// Unit outward normal of face f. Throws std::invalid_argument when f is out of range.
  Eigen::Vector3d face_normal(int f) const;
  /// Area of face f, m^2. Throws std::invalid_argument when f is out of range.
  double face_area(int f) const;
  /// Unit outward normals of all faces, (F,3).
  Points face_normals() const;
};

/// Options for load_mesh() and make_mesh().
struct MeshLoadOptions {
  double scale = 1.0;           ///< multiply coordinates by this (0.001 loads millimetres as metres)
  /// Vertices closer than this fraction of the bounding-box diagonal are welded into the first of
  /// them (0: only exactly equal vertices). A triangle whose corners lie within this distance of a
  /// line is degenerate.
  double weld_tolerance = 1e-9;
  bool orient = true;           ///< make the winding consistent and outward (see Mesh)
};

/// Loads a mesh file and returns it validated and cleaned.
///
/// Formats: STL (ASCII/binary), OBJ, COLLADA, OFF and the rest of what assimp reads; PLY
/// (ASCII, binary little- and big-endian) by pairgrasp's own reader, which checks every count
/// against the file. COLLADA files are checked for the malformations that make assimp hang or
/// crash before assimp parses them. Points and lines are ignored, polygons are triangulated
/// (ear clipping in their plane, keeping their winding). All meshes of the file's scene are merged with
/// their node transforms applied (a mirroring transform reverses its faces' winding so that
/// they stay outward). COLLADA files keep their authored axes (no Z-up to Y-up rotation, as
/// RViz does) and their top-level `<asset><unit meter="...">` is applied exactly once, then
/// `options.scale`. Throws FileError naming the file (missing, unreadable, unsupported or
/// malformed, no triangles, NaN/inf vertices or coordinates beyond 1e100 m (whose areas would
/// overflow), out-of-range indices, bad `<unit>`);
/// std::invalid_argument for a non-positive or non-finite scale or a negative weld tolerance.
Mesh load_mesh(const std::string& path, const MeshLoadOptions& options = {});

/// Builds a mesh from arrays with the same validation and clean-up as load_mesh().
/// `name` becomes Mesh::source and is used in error messages. Throws std::invalid_argument
/// naming the argument ("vertices", "faces") for non-finite vertices or coordinates beyond
/// 1e100 m, out-of-range indices or
/// no triangles, and for bad options.
Mesh make_mesh(const Points& vertices, const Triangles& faces, const std::string& name = "mesh",
               const MeshLoadOptions& options = {});

}  // namespace pairgrasp
