#pragma once
/// @file collision.hpp
/// Penetration pruning: the hand's links against the target and optional obstacles, at a wrist
/// pose and a DOF vector, through FCL (triangle intersections) and dense surface samples (depth,
/// and links wholly inside, which FCL cannot see).
///
/// Frames: the wrist pose maps wrist coordinates to target coordinates, p_T = R·p_G + t.
/// Obstacles are given in the target frame. Lengths are metres.
#include <pairgrasp/free_surface.hpp>
#include <pairgrasp/hand.hpp>
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/surface_query.hpp>
#include <pairgrasp/types.hpp>

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace pairgrasp {

/// A mesh in the scene that the hand must not touch (a table, the hand holding the target),
/// in the target frame.
struct Obstacle {
  std::string name;  ///< used in reports ("table")
  Mesh mesh;
};

/// Options of GraspChecker.
struct CheckOptions {
  /// Penetration depth (m) tolerated before a pose is pruned. Set it from the unit-facet edge
  /// h of the alignment, about 0.25·h: alignments are only accurate to a fraction of h. The
  /// default, 1.25 mm, is 0.25·h for h = 5 mm.
  double depth_tolerance = 0.00125;
  /// Contact gap (m): surfaces closer than this touch. A link within it of an occluded target
  /// face prunes the pose; closing stops a finger within it; contacts are the active-surface
  /// points within it of the target.
  double contact_gap = 0.001;
  /// Spacing (m) of the dense samples of every link surface (and of the target's) used to
  /// measure penetration depth; 0 means depth_tolerance. Depth is exact at the samples, so it is
  /// under-estimated by at most about this spacing on flat intrusions.
  double sample_spacing = 0.0;
  /// Spacing (m) of the samples of the active surfaces used for contacts.
  double contact_spacing = 0.001;
  /// Contacts are thinned to one per cube of this edge (m) per link (target frame grid).
  double contact_cell = 0.004;
  /// Threads of check_many(): 0 = all cores.
  int threads = 0;
  /// Check through distance fields (a narrow-band signed-distance grid of the target, one of the
  /// occluded faces, face planes of convex links, small grids of the others), with the exact
  /// queries deciding wherever a field value lies within its error bound of a threshold: every
  /// flag (pruned, penetrating, obstacle_collision, touches_occluded, collision, colliding,
  /// intersecting, inside) equals the exact path's, and every depth lies within field_cell·√3/2
  /// of its exact value (exact_depth) or is a lower bound of it beyond the tolerance (as with
  /// exact_depth false). False: the exact path (FCL and signed-distance queries at every sample).
  bool use_distance_field = true;
  /// Cell edge (m) of the distance fields; their interpolation error is at most (√3/2)·cell.
  double field_cell = 0.001;
  /// The plane the target rests on (target frame), when it does. Settling a candidate
  /// (candidates.hpp) first lifts the hand along the plane's normal until every link vertex lies
  /// `contact_gap` above it, and drops the candidate at once when that takes more than the largest
  /// back-off.
  /// The checks here do not read it: give the support as an obstacle too (support_box()).
  std::optional<SupportPlane> support;
};

/// An estimate of the peak bytes of the distance fields a GraspChecker with `options` builds for
/// `target` and its occluded faces (`free`: per face, true = free; the links' fields are small):
/// DistanceField::estimate_bytes() of each, in microseconds. 0 without distance fields.
std::size_t estimate_field_bytes(const Mesh& target, const Mask& free, const CheckOptions& options);

/// How one link at a pose meets the target, the obstacles and the occluded faces
/// (GraspChecker::link_status()).
struct LinkStatus {
  /// The link alone would make check() prune: it penetrates the target beyond the depth
  /// tolerance, intersects or lies inside an obstacle, or comes within the contact gap of an
  /// occluded face.
  bool pruned = false;
  bool penetrating = false;  ///< beyond the depth tolerance in the target, or in an obstacle
  /// Deepest penetration into anything (m), searched as check() with exact_depth false: a lower
  /// bound beyond the tolerance.
  double depth = 0.0;
};

class GraspChecker;
namespace detail {
struct CheckerAccess;  // the closing and contact functions' access to the checker's state
}  // namespace detail

/// What one link collides with.
struct CollisionPair {
  std::string link;          ///< hand link name
  std::string other;         ///< "target" or the obstacle's name
  bool obstacle = false;     ///< `other` is an obstacle
  bool intersecting = false; ///< FCL found intersecting triangles
  bool inside = false;       ///< some sample of one lies strictly inside the other
  double depth = 0.0;        ///< deepest sample (m): link samples inside `other`, and target samples inside the link
};

/// Per-link result.
struct LinkCheck {
  std::string link;              ///< hand link name
  bool colliding = false;        ///< intersects, or lies (partly) inside, the target or an obstacle
  double depth = 0.0;            ///< deepest penetration of this link into anything (m)
  bool touches_occluded = false; ///< within contact_gap of (or intersecting) an occluded target face
  std::vector<std::string> with; ///< what it collides with ("target", obstacle names)
};

/// Result of GraspChecker::check().
struct CheckResult {
  std::vector<LinkCheck> links;      ///< one per Hand::links(), in that order
  std::vector<CollisionPair> pairs;  ///< every colliding (link, target/obstacle) pair
  bool collision = false;            ///< any link collides with anything (any depth)
  double depth = 0.0;                ///< largest depth over links and targets/obstacles (m)
  double target_depth = 0.0;         ///< largest depth against the target (m)
  bool penetrating = false;          ///< target_depth > depth_tolerance
  bool obstacle_collision = false;   ///< a link intersects or is inside an obstacle
  bool touches_occluded = false;     ///< a link touches occluded target faces
  bool pruned = false;               ///< penetrating || obstacle_collision || touches_occluded
  std::string reason;                ///< why it is pruned (empty when kept)
};

/// Checks hand poses against a target and obstacles. Built once (FCL BVH models of every link,
/// of the target, of its occluded faces and of every obstacle; dense samples of every link and
/// of the target), then queried from any number of threads.
///
/// **Depth.** FCL's mesh–mesh test reports intersecting triangles, but a link wholly inside the
/// target intersects nothing. So a link collides with a closed mesh when FCL finds triangle
/// intersections or one of its samples lies strictly inside the mesh (a link with no
/// intersection is wholly inside or wholly outside: one vertex per connected component decides),
/// and its depth is the largest distance to the mesh's surface over its samples inside it.
/// Against the target the converse is measured too (target samples inside a closed link), so
/// that a sharp target corner poking into a flat link is not under-estimated. An open obstacle
/// only reports intersections (depth 0). Self-collision of the hand is not checked.
///
/// **Pruning.** A pose is pruned when its depth into the target exceeds depth_tolerance, when a
/// link intersects or is inside an obstacle (any depth), or when a link comes within
/// contact_gap of an occluded target face (free mask false) or intersects one.
class GraspChecker {
 public:
  /// `free`: per-face mask of the target (true = free; empty: all free). Throws
  /// std::invalid_argument for a target or obstacle with no faces, a mask of the wrong size
  /// ("free: expected F, got n"), a mask with no free face ("no free face left: ..."), a
  /// negative or non-finite option (naming it), or sample counts beyond 20 million.
  GraspChecker(const Hand& hand, const Mesh& target, const Mask& free = Mask(),
               const std::vector<Obstacle>& obstacles = {}, const CheckOptions& options = {});
  /// The target as free_surface() split it from `given`: `surface.mesh` with the mask
  /// `surface.free`, as above, but its FCL model (the triangle tests and exact distances) built
  /// from `given`, the same surface in fewer faces. The split multiplies the faces where a mark
  /// changes (a part lying on a table: 2,475 faces become 17,982), and FCL's distance near the
  /// surface costs with them. Throws std::invalid_argument ("surface: ...") when
  /// `surface.source_faces` does not index `given`'s faces or the two span different boxes, and
  /// as above.
  GraspChecker(const Hand& hand, const FreeSurface& surface, const Mesh& given,
               const std::vector<Obstacle>& obstacles = {}, const CheckOptions& options = {});

  /// Checks one wrist pose (target frame) and DOF vector. Throws std::invalid_argument for a
  /// non-rigid or non-finite wrist ("wrist: ..."), a DOF vector of the wrong size or outside
  /// the limits ("dofs: ...").
  ///
  /// With `exact_depth` false, each link's depth search stops once the link is known to prune the
  /// pose (a depth beyond depth_tolerance in the target, any depth in an obstacle): `pruned`,
  /// `penetrating` and every flag are unchanged, a depth beyond the tolerance is a lower bound of
  /// the true depth (a depth within it stays exact), and so is the depth `reason` names. Several
  /// times faster on deeply penetrating poses, for searches that only need to know whether a pose
  /// is pruned.
  CheckResult check(const Pose& wrist, const Eigen::VectorXd& dofs, bool exact_depth = true) const;
  /// check() for every (wrists[k], dofs[k]) on `threads` threads (-1: options().threads; 0: all
  /// cores). Results are identical to serial check() calls, in input order. Sizes must match.
  std::vector<CheckResult> check_many(const std::vector<Pose>& wrists,
                                      const std::vector<Eigen::VectorXd>& dofs,
                                      int threads = -1, bool exact_depth = true) const;

  /// Link `link` (Hand::links() index) at `pose` (target frame) alone: the per-link part of check()
  /// without its report, for code that checks again only the links a change moved. Thread-safe.
  /// Throws std::invalid_argument ("link: ...") for an index out of range.
  LinkStatus link_status(int link, const Pose& pose) const;
  /// check()'s verdict without its report (stops at the first link that prunes), for the hand at
  /// `wrist` with its links at `link_poses` (wrist frame: Hand::link_poses(dofs, true)).
  bool pruned(const Pose& wrist, const std::vector<Pose>& link_poses) const;
  /// Whether some link at `wrist` and `link_poses` penetrates (LinkStatus::penetrating). Closing
  /// never moves such a link (close_fingers()), so the closed grasp is pruned too.
  bool penetrating(const Pose& wrist, const std::vector<Pose>& link_poses) const;
  /// Per DOF, the links (Hand::links() indices) whose pose changes when it moves.
  const std::vector<std::vector<int>>& dof_links() const;

  const Hand& hand() const;
  const Mesh& target() const;
  /// The target's per-face free mask (all true when none was given).
  const Mask& free() const;
  const std::vector<Obstacle>& obstacles() const;
  const CheckOptions& options() const;
  /// Queries on the target (closest point, signed distance).
  const SurfaceQuery& target_query() const;
  /// Number of depth samples of each link (Hand::links() order) and of the target.
  std::vector<int> link_sample_counts() const;
  int target_sample_count() const;
  /// Bytes held by the distance fields (0 without use_distance_field) and the seconds spent
  /// building them.
  std::size_t distance_field_bytes() const;
  double distance_field_seconds() const;

 private:
  struct Impl;  // defined in the library's sources
  friend struct detail::CheckerAccess;
  std::shared_ptr<const Impl> impl_;
};

/// Throws std::invalid_argument("<what>: ...") unless `pose` is finite and rigid (orthonormal
/// rotation with determinant +1 to 1e-6, last row 0 0 0 1).
void check_rigid(const Pose& pose, const char* what);

}  // namespace pairgrasp
