#pragma once
// Internal state of GraspChecker, shared by collision.cpp (checks) and grasp*.cpp (closing,
// contacts). FCL stays inside cpp/src.
#include <pairgrasp/collision.hpp>
#include <pairgrasp/distance_field.hpp>

#include "surface_query_internal.hpp"

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/math/bv/OBBRSS.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace pairgrasp {

namespace geometry_detail {

using FclModel = fcl::BVHModel<fcl::OBBRSSd>;

/// FCL BVH model of the given faces (all when `subset` is empty). Null when there is no face.
std::shared_ptr<FclModel> make_fcl_model(const Points& vertices, const Triangles& faces,
                                         const std::vector<int>& subset = {});

/// Bounds of the given faces' vertices.
Eigen::AlignedBox3d faces_bounds(const Points& vertices, const Triangles& faces,
                                 const std::vector<int>& subset = {});

/// Axis-aligned box of `box` moved by `pose`.
Eigen::AlignedBox3d transform_box(const Eigen::AlignedBox3d& box, const Pose& pose);

/// Whether box `a` comes within `gap` (m) of box `b` (they intersect once `b` is grown by `gap`).
inline bool boxes_within(const Eigen::AlignedBox3d& a, Eigen::AlignedBox3d b, double gap) {
  b.min().array() -= gap;
  b.max().array() += gap;
  return a.intersects(b);
}

/// Samples of a surface with the connected component of each, plus a vertex of each component.
struct SurfaceSamples {
  Points points;                  ///< (S,3) in the mesh's frame
  std::vector<int> component;     ///< (S) component of each sample
  std::vector<Vec3> component_rep;  ///< one vertex of each component
  Bvh tree;                       ///< tree over the points
};
SurfaceSamples make_samples(const Mesh& mesh, double spacing);

/// Flags in `inside` the connected components of `samples` whose representative vertex, mapped
/// into B's frame by `to_b`, lies in `b_bounds` and passes `is_inside(q)`: where the surfaces do
/// not cross, a component lies wholly inside B or wholly outside. Returns whether any does.
template <class IsInside>
bool components_inside(const SurfaceSamples& samples, const Pose& to_b, const Eigen::AlignedBox3d& b_bounds,
                       IsInside&& is_inside, std::vector<char>& inside) {
  inside.assign(samples.component_rep.size(), 0);
  bool any = false;
  for (std::size_t c = 0; c < inside.size(); ++c) {
    const Vec3 q = to_b * samples.component_rep[c];
    if (b_bounds.contains(q) && is_inside(q)) inside[c] = any = true;
  }
  return any;
}

/// max(known, largest depth (m) of the samples inside the closed mesh of `b` (bounds
/// `b_bounds`, in B's frame)), the samples mapped into B's frame by `to_b`. When `components` is
/// not empty only samples of flagged components count. Best-first branch and bound over the
/// samples' tree: signed distance is 1-Lipschitz, so a node's ball is skipped when it is wholly
/// outside or cannot beat the best depth so far (starting from `known`). The search stops as soon
/// as a depth beyond `stop` (m) is found; that depth is then a lower bound of the largest.
double deepest_inside(const SurfaceSamples& samples, const Pose& to_b, const SurfaceQuery& b,
                      const Eigen::AlignedBox3d& b_bounds, const std::vector<char>& components,
                      double known = 0.0, double stop = std::numeric_limits<double>::infinity());

/// Bounds of an exact signed distance (m): lower <= exact <= upper.
struct Interval {
  double value = 0.0;  ///< estimate
  double lower = 0.0;
  double upper = 0.0;
  bool tight = true;   ///< within the field's documented error of the exact value
};

/// Bounds of a link's signed distance in its own frame: exact inside a convex link (the largest
/// face-plane offset; outside it a lower bound), else the link's distance field.
struct LinkDistance {
  std::vector<Eigen::Vector4d> planes;   ///< convex link: unit outward normal, offset (n·p - d)
  std::unique_ptr<DistanceField> field;  ///< non-convex closed link
  double slack = 0.0;                    ///< rounding of the plane form (m)
  Interval at(const Vec3& q) const;
};

/// A triangle (corners in some frame).
using Tri = std::array<Vec3, 3>;

/// Bounding balls of a surface: its triangles split (longest edge first) into pieces of
/// circumradius at most a leaf radius, under a binary tree per connected component. A node's
/// ball (centre, radius, in the mesh's frame) holds every piece below it (their corners, hence
/// the pieces), and `rep` is a point of the surface in it (a piece's centroid).
struct SphereTree {
  struct Node {
    Vec3 centre = Vec3::Zero();
    Vec3 rep = Vec3::Zero();
    double radius = 0.0;
    std::int32_t left = -1;  ///< children left and left + 1; -1 for a leaf (one piece)
  };
  std::vector<Node> nodes;
  std::vector<std::int32_t> roots;  ///< one per connected component with faces
  bool empty() const { return nodes.empty(); }
};
/// Sphere tree of the given faces of `mesh` (all when `faces` is empty).
SphereTree make_sphere_tree(const Mesh& mesh, const std::vector<int>& faces, double leaf_radius);

/// Result of a depth search on bounds (see GraspChecker::Impl::field_pair): lo <= exact <= hi,
/// est within the field's interpolation error of the exact depth.
struct DepthBounds {
  double est = 0.0, lo = 0.0, hi = 0.0;
};

/// A hand link ready for checks.
struct LinkModel {
  std::string name;
  const HandLink* link = nullptr;  ///< in the Hand held by the checker
  std::shared_ptr<FclModel> fcl;          ///< every face
  std::shared_ptr<FclModel> fcl_active;   ///< active faces only (null when none)
  Eigen::AlignedBox3d bounds;             ///< link frame
  std::unique_ptr<SurfaceQuery> query;    ///< of the link mesh (for target samples inside it)
  SurfaceSamples samples;                 ///< depth samples, link frame
  Points contact_samples;                 ///< active-surface samples at contact_spacing, link frame
  LinkDistance distance;                  ///< signed distance bounds inside the link (closed links)
  std::vector<Tri> tris;                  ///< faces, link frame
  SphereTree surface;                     ///< every face, link frame (distance fields only)
  SphereTree active_surface;              ///< active faces, link frame (distance fields only)
};

/// The target or an obstacle.
struct SceneModel {
  std::string name;
  bool obstacle = false;
  const Mesh* mesh = nullptr;
  std::shared_ptr<FclModel> fcl;
  Eigen::AlignedBox3d bounds;
  std::unique_ptr<SurfaceQuery> query;
  SurfaceSamples samples;  ///< target only (reverse depth); empty for obstacles
  std::unique_ptr<DistanceField> field;  ///< target's distance field (null: exact queries)
};

/// What a link at a pose does against one scene model.
struct PairCheck {
  bool near = false;          ///< boxes within the contact gap
  bool intersecting = false;  ///< FCL triangle intersection
  bool inside = false;        ///< a sample strictly inside the other
  double depth = 0.0;
};

}  // namespace geometry_detail

struct GraspChecker::Impl {
  using LinkState = LinkStatus;
  Hand hand;
  Mesh target;
  Mask free;
  std::vector<Obstacle> obstacles;
  CheckOptions options;
  double sample_spacing = 0.0;

  std::vector<geometry_detail::LinkModel> links;
  std::vector<geometry_detail::SceneModel> scene;  ///< [0] target, then obstacles
  std::shared_ptr<geometry_detail::FclModel> occluded;  ///< target's occluded faces (null: none)
  Eigen::AlignedBox3d occluded_bounds;
  std::unique_ptr<SurfaceQuery> occluded_query;   ///< the occluded faces alone (unsigned)
  std::unique_ptr<DistanceField> occluded_field;  ///< unsigned distance to the occluded faces

  /// Links (indices into links) whose pose changes with each DOF.
  std::vector<std::vector<int>> dof_links;

  /// `geometry`: the mesh the target's FCL model is built from, the same surface as `target` in
  /// other faces (null: `target` itself).
  Impl(const Hand& hand, const Mesh& target, const Mask& free, const std::vector<Obstacle>& obstacles,
       const CheckOptions& options, const Mesh* geometry = nullptr);

  /// One link (index l, pose in the target frame) against scene model s. The depth searches stop
  /// once a depth beyond `stop` (m) is found (a lower bound then).
  geometry_detail::PairCheck check_pair(int l, const Pose& pose, int s,
                                          double stop = std::numeric_limits<double>::infinity()) const;
  /// Whether link l at `pose` comes within the contact gap of an occluded target face.
  bool touches_occluded(int l, const Pose& pose) const;
  /// check_pair() through the distance fields: the same flags, depth within the field's bound;
  /// the exact check_pair() decides wherever the bounds do not.
  ///
  /// `intersection` false, for callers that need neither `intersecting` nor the depth itself, only
  /// whether it exceeds options.depth_tolerance (a link's state while settling and closing): where
  /// the fields leave the triangle test open, FCL is not asked; the depth search takes every sample
  /// instead of the components FCL would leave (the same deepest sample: a component that does not
  /// cross the surface has none inside), `intersecting` stays false, and the search ends once the
  /// depth is known to lie beyond the tolerance or within it. `depth` is then a certain lower bound
  /// beyond the tolerance (as with `stop`), and within it an estimate in the search's bounds, 0 when
  /// no sample is known to lie inside. The exact check_pair() ignores the flag.
  geometry_detail::PairCheck field_pair(int l, const Pose& pose, int s,
                                          double stop = std::numeric_limits<double>::infinity(),
                                          bool intersection = true) const;
  /// field_pair() or check_pair(), as options.use_distance_field says.
  geometry_detail::PairCheck pair(int l, const Pose& pose, int s,
                                    double stop = std::numeric_limits<double>::infinity(),
                                    bool intersection = true) const {
    return options.use_distance_field ? field_pair(l, pose, s, stop, intersection) : check_pair(l, pose, s, stop);
  }
  /// touches_occluded() through the occluded faces' distance field (exact where undecided).
  bool field_touches_occluded(int l, const Pose& pose) const;
  /// Builds the distance fields (target, occluded faces, non-convex links).
  void build_fields();
  void build_link_field(geometry_detail::LinkModel& link, double cell, double band);
  double field_seconds = 0.0;
  /// What one link at `pose` (target frame) does, without strings (GraspChecker::link_status();
  /// `depth` within the tolerance is only an estimate, see field_pair()'s `intersection`).
  LinkState link_state(int l, const Pose& pose) const;
  /// True when the target's distance field proves that link l's active faces at `pose` (target
  /// frame) come within `gap` of the target (a point of them whose field interval reaches no
  /// farther than `gap`); false when it cannot tell. Never true where link_distance(l, pose, true)
  /// exceeds `gap`.
  bool active_within(int l, const Pose& pose, double gap) const;
  /// Whether the hand at `wrist` with its links at `link_poses` (wrist frame) would be pruned: the
  /// verdict of check(), without its report (stops at the first bad link).
  bool pruned(const Pose& wrist, const std::vector<Pose>& link_poses) const;
  /// Whether some link at `wrist` and `link_poses` penetrates (LinkState::penetrating). Closing
  /// never moves such a link (close_fingers()), so the closed grasp is pruned too.
  bool penetrating(const Pose& wrist, const std::vector<Pose>& link_poses) const;
  /// Full check at link poses already in the target frame (depths exact unless `exact_depth` is
  /// false: see GraspChecker::check).
  /// `clear` (optional, one flag per link): links known to be apart from the target and every
  /// obstacle at their pose (a certain positive clearance), whose collision pairs are not searched;
  /// their occluded-face test still is.
  CheckResult check_poses(const std::vector<Pose>& poses, bool exact_depth = true,
                          const std::vector<char>* clear = nullptr) const;
  /// Link poses in the target frame.
  std::vector<Pose> target_frame_poses(const Pose& wrist, const Eigen::VectorXd& dofs) const;
  /// Smallest FCL distance (m) between link l at `pose` (its active faces only when `active`;
  /// inf when it has none) and the target and obstacles; 0 when they intersect.
  double link_distance(int l, const Pose& pose, bool active) const;
  /// link_distance(), or, where the target's distance field shows that it exceeds `above` (m), a
  /// lower bound of it that exceeds `above` (then `exact` is set false); 0 without an FCL query
  /// where the field shows the surfaces crossing. Without the fields: link_distance().
  double link_clearance(int l, const Pose& pose, bool active, double above, bool* exact = nullptr) const;
};

namespace detail {
/// The library's access to a GraspChecker's state (the closing and contact functions of grasp.hpp).
struct CheckerAccess {
  using Impl = GraspChecker::Impl;
  static const Impl& impl(const GraspChecker& checker) { return *checker.impl_; }
};
}  // namespace detail

}  // namespace pairgrasp
