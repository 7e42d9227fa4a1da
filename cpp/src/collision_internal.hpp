#pragma once
// Internal state of GraspChecker, shared by collision.cpp (checks) and grasp*.cpp (closing,
// contacts). FCL stays inside cpp/src.
#include <pairgrasp/collision.hpp>

#include "surface_query_internal.hpp"

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/math/bv/OBBRSS.h>

#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace pairgrasp {

namespace validation_detail {

using FclModel = fcl::BVHModel<fcl::OBBRSSd>;

/// FCL BVH model of the given faces (all when `subset` is empty). Null when there is no face.
std::shared_ptr<FclModel> make_fcl_model(const Points& vertices, const Triangles& faces,
                                         const std::vector<int>& subset = {});

/// Bounds of the given faces' vertices.
Eigen::AlignedBox3d faces_bounds(const Points& vertices, const Triangles& faces,
                                 const std::vector<int>& subset = {});

/// Axis-aligned box of `box` moved by `pose`.
Eigen::AlignedBox3d transform_box(const Eigen::AlignedBox3d& box, const Pose& pose);

/// Samples of a surface with the connected component of each, plus a vertex of each component.
struct SurfaceSamples {
  Points points;                  ///< (S,3) in the mesh's frame
  std::vector<int> component;     ///< (S) component of each sample
  std::vector<Vec3> component_rep;  ///< one vertex of each component
  Bvh tree;                       ///< tree over the points
};
SurfaceSamples make_samples(const Mesh& mesh, double spacing);

/// max(known, largest depth (m) of the samples inside the closed mesh of `b` (bounds
/// `b_bounds`, in B's frame)), the samples mapped into B's frame by `to_b`. When `components` is
/// not empty only samples of flagged components count. Best-first branch and bound over the
/// samples' tree: signed distance is 1-Lipschitz, so a node's ball is skipped when it is wholly
/// outside or cannot beat the best depth so far (starting from `known`). The search stops as soon
/// as a depth beyond `stop` (m) is found; that depth is then a lower bound of the largest.
double deepest_inside(const SurfaceSamples& samples, const Pose& to_b, const SurfaceQuery& b,
                      const Eigen::AlignedBox3d& b_bounds, const std::vector<char>& components,
                      double known = 0.0, double stop = std::numeric_limits<double>::infinity());

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
};

/// What a link at a pose does against one scene model.
struct PairCheck {
  bool near = false;          ///< boxes within the contact gap
  bool intersecting = false;  ///< FCL triangle intersection
  bool inside = false;        ///< a sample strictly inside the other
  double depth = 0.0;
};

}  // namespace validation_detail

struct GraspChecker::Impl {
  Hand hand;
  Mesh target;
  Mask free;
  std::vector<Obstacle> obstacles;
  CheckOptions options;
  double sample_spacing = 0.0;

  std::vector<validation_detail::LinkModel> links;
  std::vector<validation_detail::SceneModel> scene;  ///< [0] target, then obstacles
  std::shared_ptr<validation_detail::FclModel> occluded;  ///< target's occluded faces (null: none)
  Eigen::AlignedBox3d occluded_bounds;

  /// Links (indices into links) whose pose changes with each DOF.
  std::vector<std::vector<int>> dof_links;

  Impl(const Hand& hand, const Mesh& target, const Mask& free, const std::vector<Obstacle>& obstacles,
       const CheckOptions& options);

  /// One link (index l, pose in the target frame) against scene model s. The depth searches stop
  /// once a depth beyond `stop` (m) is found (a lower bound then).
  validation_detail::PairCheck check_pair(int l, const Pose& pose, int s,
                                          double stop = std::numeric_limits<double>::infinity()) const;
  /// Whether link l at `pose` comes within the contact gap of an occluded target face.
  bool touches_occluded(int l, const Pose& pose) const;
  /// Full check at link poses already in the target frame (depths exact unless `exact_depth` is
  /// false: see GraspChecker::check).
  CheckResult check_poses(const std::vector<Pose>& poses, bool exact_depth = true) const;
  /// Link poses in the target frame.
  std::vector<Pose> target_frame_poses(const Pose& wrist, const Eigen::VectorXd& dofs) const;
  /// Smallest FCL distance (m) between link l at `pose` (its active faces only when `active`;
  /// inf when it has none) and the target and obstacles; 0 when they intersect.
  double link_distance(int l, const Pose& pose, bool active) const;
};

}  // namespace pairgrasp
