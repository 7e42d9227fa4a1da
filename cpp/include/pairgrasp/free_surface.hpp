#pragma once
/// @file free_surface.hpp
/// The free surface of a target: which part of it a gripper may touch, decided per surface patch
/// (a piece of a face no longer than a resolution, about h/2), not per mesh face.
///
/// The marks: a paint mask (whole faces, as paint files list them) and paint regions, occluders
/// (a holder, a hand around an instrument, a table mesh), viewpoints (the surface no camera sees)
/// and a support plane (the table the target stands on). A coarse mesh's long side face that
/// touches a table along one edge is split where the mark changes, so that it stays free above
/// the occluded strip. The result is the target refined where a mark changes (the same surface,
/// conforming: no T-junction, so a closed target stays closed) with one free flag per face, which
/// tessellation, alignment, collision, contacts, epsilon and the pictures all read.
///
/// Lengths are metres.
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/paint.hpp>
#include <pairgrasp/types.hpp>

#include <limits>
#include <optional>
#include <vector>

namespace pairgrasp {

/// A plane the target rests on (a table): every point p with height(p) < 0 is below it.
struct SupportPlane {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< a point of the plane, metres
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ(); ///< up, away from the support; non-zero, any length

  /// The plane through the lowest point of `target` along `up` (non-zero, any length), normal `up`.
  /// Throws std::invalid_argument for a mesh without vertices or a zero or non-finite `up`.
  static SupportPlane below(const Mesh& target, const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ());
  /// The plane of a face of `obstacle` that `target` stands on, when there is one (a table given
  /// as a mesh; a wall it leans on is one too): the obstacle lies wholly below the plane, the
  /// target wholly above it (within
  /// 1e-6 m) with its lowest point within `distance` (m) of it, and the obstacle's extent in the
  /// plane covers the target's. The largest such face's plane; nullopt when none, for an empty
  /// mesh, or for an obstacle of more than 5,000 faces (not searched).
  static std::optional<SupportPlane> under(const Mesh& target, const Mesh& obstacle, double distance);
  /// Throws std::invalid_argument ("support: ...") for a non-finite point or normal or a zero normal.
  void validate() const;
  /// Signed height of p above the plane, metres (the normal taken unit).
  double height(const Eigen::Vector3d& p) const;
};

/// What covers part of a target's surface (everything in the target frame).
struct Occlusion {
  /// Per face of the target, true = free (empty: every face free): a paint file's face lists.
  Mask paint;
  /// Applied in order over `paint` at every point of the surface (paint files' regions): later
  /// regions override earlier ones.
  std::vector<PaintRegion> regions;
  /// A point within `distance` of an occluder's surface, or inside a closed occluder, is occluded.
  std::vector<Mesh> occluders;
  /// A point within this of an occluder or of the support plane is occluded (m, >= 0).
  double distance = 0.005;
  /// (V,3): only what some viewpoint sees stays free (empty: no visibility test). A patch is seen
  /// from v when it faces v and the segment from one of its sample points (its centroid and the
  /// points 80 % of the way to its corners) to v meets neither the target nor an occluder.
  Points viewpoints;
  /// The plane the target rests on: within `distance` of it, or below it, is occluded.
  std::optional<SupportPlane> support;
};

/// The target with its free surface at patch resolution.
struct FreeSurface {
  /// The target with faces split (midpoints, conforming) where a mark changes, down to
  /// `resolution`, and their neighbours split at the shared edges' midpoints (no T-junction);
  /// faces away from a change are the target's, unchanged. The same surface.
  Mesh mesh;
  Mask free;                  ///< per face of `mesh`, true = free
  Eigen::VectorXi source_faces;  ///< per face of `mesh`: the target face it lies in
  double resolution = 0.0;    ///< longest edge (m) of a patch a mark still divides
  int split_faces = 0;        ///< target faces that were split (0: `mesh` is the target)
};

/// The free surface of `target` under `occlusion`, with patches of at most `resolution` metres
/// where a mark changes (infinity: whole faces, no split).
///
/// Each face is classified against every mark as wholly free, wholly occluded or divided:
/// - paint and regions: the mark at its corners, edge midpoints and centroid; a divided patch takes
///   its centroid's mark;
/// - an occluder: exactly, from the triangle-to-triangle distance (beyond `distance`: free, unless
///   inside a closed occluder) and from one occluder triangle within `distance` of all three
///   corners (wholly occluded, since the distance to a triangle is convex); a divided patch is
///   occluded (some point of it is within reach);
/// - the support plane: exactly, from the corners' heights (linear over a face); divided: occluded;
/// - viewpoints: the sample points; divided: free (one of them is seen).
/// A face wholly occluded by one mark is occluded; a divided face longer than `resolution` is
/// bisected at its longest edge's midpoint (the neighbour splitting the shared edge too, so the
/// pieces grow with the length of a mark's boundary, not with the area of the faces it crosses) and
/// its pieces classified again. So every point more than `distance + resolution` from an occluder or
/// the support is free (paint and viewpoints permitting), and every point within `distance` of one
/// is occluded. Deterministic; uses `threads` (0: every core).
///
/// Throws std::invalid_argument naming the field: a non-positive or NaN resolution
/// ("resolution: ..."), a paint mask of the wrong size ("paint: expected F, got n"), a bad region
/// ("regions[i]..."), an occluder with no faces ("occluders[i]: ..."), a negative or non-finite
/// distance ("distance: ..."), a non-finite viewpoint ("viewpoints: row i ..."), a bad support
/// plane ("support: ...") or one that cuts through the target (its lowest point more than 0.1 %
/// of the target's diagonal below it: "support: ... cuts through the target ..."), and, when no
/// patch is left free, "no free face left: ..." naming the marks that covered it.
FreeSurface free_surface(const Mesh& target, const Occlusion& occlusion,
                         double resolution = std::numeric_limits<double>::infinity(), int threads = 0);

/// Per-face free mask of `target` (whole faces, as free_surface() at infinite resolution): a face
/// is occluded when some point of it lies within `distance` (m, >= 0) of an occluder's surface or
/// it lies inside a closed occluder, ANDed with `free` (empty: all free). Throws as free_surface().
Mask occluded_by(const Mesh& target, const std::vector<Mesh>& occluders, double distance,
                 const Mask& free = Mask(), int threads = 0);

/// Per-face free mask of `target`: a face is free when some viewpoint sees one of its sample points
/// (as free_surface() at infinite resolution), ANDed with `free` (empty: all free). Throws as
/// free_surface(); "viewpoints: expected at least one viewpoint" for none.
Mask visible_from(const Mesh& target, const Points& viewpoints, const Mask& free = Mask(),
                  const std::vector<Mesh>& occluders = {}, int threads = 0);

/// AND of two free masks of the same size. Throws std::invalid_argument for different sizes
/// ("b: expected F, got n") or when no face is left free ("no free face left: ...").
Mask combine_free(const Mask& a, const Mask& b);

/// The support as an obstacle: a box whose top face lies on the plane, covering the target's
/// footprint on it widened by `margin` on every side, and `margin` deep (m, > 0). Named "support".
/// Throws std::invalid_argument for a bad plane or margin.
Mesh support_box(const SupportPlane& support, const Mesh& target, double margin);

}  // namespace pairgrasp
