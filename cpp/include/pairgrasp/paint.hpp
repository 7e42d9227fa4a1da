#pragma once
/// @file paint.hpp
/// Paint: which faces of a target a gripper may touch (free) and which it may not (occluded).
///
/// The paper's sensor "paints" the target's facets; here a paint file (JSON, format in
/// models/README.md) or a list of regions gives one mask per face of a Mesh, true = free.
/// Regions test face centroids, so masks can be built the same way from code (occluders,
/// viewpoints) as from files.
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/types.hpp>

#include <string>
#include <vector>

namespace pairgrasp {

/// A region of space that marks every face whose centroid lies inside it as free or occluded.
struct PaintRegion {
  /// The kinds of region.
  enum class Shape {
    halfspace,  ///< points p with (p - point) . normal >= 0 (the side the normal points to)
    box,        ///< points p with min <= p <= max on every axis
    sphere,     ///< points p with |p - center| <= radius
    cylinder    ///< points within radius of the segment start-end whose projection falls on it
  };

  Shape shape = Shape::halfspace;                    ///< which of the fields below apply
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< halfspace: a point on its plane, metres
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ(); ///< halfspace: towards the inside; non-zero, any length
  Eigen::Vector3d min = Eigen::Vector3d::Zero();     ///< box: lower corner, metres
  Eigen::Vector3d max = Eigen::Vector3d::Zero();     ///< box: upper corner, metres (>= min per axis)
  Eigen::Vector3d center = Eigen::Vector3d::Zero();  ///< sphere: centre, metres
  Eigen::Vector3d start = Eigen::Vector3d::Zero();   ///< cylinder: centre of one end, metres
  Eigen::Vector3d end = Eigen::Vector3d::UnitZ();    ///< cylinder: centre of the other end (!= start)
  double radius = 0.0;                               ///< sphere, cylinder: radius, metres (> 0)
  bool free = false;                                 ///< the mark given: true = free, false = occluded

  /// A half-space region; throws std::invalid_argument for a non-finite point or a zero normal.
  static PaintRegion halfspace(const Eigen::Vector3d& point, const Eigen::Vector3d& normal, bool free);
  /// An axis-aligned box region; throws std::invalid_argument unless min <= max per axis (finite).
  static PaintRegion box(const Eigen::Vector3d& min, const Eigen::Vector3d& max, bool free);
  /// A ball region; throws std::invalid_argument for a non-finite centre or radius <= 0.
  static PaintRegion sphere(const Eigen::Vector3d& center, double radius, bool free);
  /// A solid cylinder region between two end centres; throws std::invalid_argument for
  /// non-finite ends, start == end, or radius <= 0.
  static PaintRegion cylinder(const Eigen::Vector3d& start, const Eigen::Vector3d& end, double radius, bool free);

  /// Throws std::invalid_argument naming the field when the fields that apply to `shape` are
  /// invalid (non-finite, zero normal, min > max, radius <= 0, start == end).
  void validate() const;
  /// Whether point p (metres) lies inside the region (boundary included).
  bool contains(const Eigen::Vector3d& p) const;
};

/// The shape's name as written in paint files: "halfspace", "box", "sphere" or "cylinder".
const char* to_string(PaintRegion::Shape shape);

/// Applies regions in order to a starting mask: each region sets the mark of every face whose
/// centroid it contains, later regions overriding earlier ones. Returns the new mask (true = free).
/// Throws std::invalid_argument when start's size is not the mesh's face count ("start: expected
/// F, got n") or a region is invalid ("regions[i].radius: ..."). An all-occluded result is
/// returned as is (callers decide whether that is an error).
Mask apply_regions(const Mesh& mesh, const std::vector<PaintRegion>& regions, const Mask& start);

/// apply_regions() starting from every face free.
Mask apply_regions(const Mesh& mesh, const std::vector<PaintRegion>& regions);

/// A paint file as read, its marks not yet applied: the face marks ("default", "free" and
/// "occluded" lists) and the regions, which free_surface() applies at patch resolution.
struct Paint {
  Mask faces;                        ///< per face of the mesh, true = free
  std::vector<PaintRegion> regions;  ///< applied in order over `faces`
};

/// Reads a paint file (models/README.md, "Paint file format") for `mesh` without applying its
/// regions. Throws FileError as load_paint() does (an all-occluded result is not an error here).
Paint read_paint(const std::string& path, const Mesh& mesh);

/// Reads a paint file (models/README.md, "Paint file format") for `mesh` and returns its per-face
/// free mask (size = mesh.faces.rows(), true = free), regions tested at face centroids (whole
/// faces; the planner applies them per patch through read_paint() and free_surface()).
///
/// Throws FileError naming the file and the field for a missing or unreadable file, invalid JSON,
/// a missing/unknown format or version, a face count other than the mesh's, an index out of range
/// or listed as both free and occluded, an unknown key, shape or mark, a non-finite number, a zero
/// normal, a box with min > max, a cylinder with start == end, or a radius <= 0.
/// Throws std::invalid_argument("<path>: paint leaves no free face") when no face is free.
Mask load_paint(const std::string& path, const Mesh& mesh);

/// Writes a paint file for `mesh` that load_paint() reads back as `free_mask`: "default" is the
/// larger side and the faces of the smaller side are listed explicitly.
///
/// Throws std::invalid_argument when free_mask's size is not the mesh's face count or no face is
/// free (such a file could not be loaded), FileError when the file cannot be written.
void save_paint(const std::string& path, const Mesh& mesh, const Mask& free_mask);

}  // namespace pairgrasp
