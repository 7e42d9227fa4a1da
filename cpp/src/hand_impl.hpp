#pragma once
// Internals of pairgrasp::Hand: the kinematic model read from a URDF and the loaded hand.
#include <pairgrasp/hand.hpp>

#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

namespace pairgrasp {
namespace hand_detail {

/// One URDF joint.
struct KJoint {
  enum Type { Fixed, Revolute, Continuous, Prismatic };
  std::string name;
  Type type = Fixed;
  int parent = -1;                            ///< index into KModel::links
  int child = -1;                             ///< index into KModel::links
  Pose origin = Pose::Identity();             ///< parent link frame -> joint frame at q = 0
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();  ///< unit, joint frame
  bool limited = false;                       ///< has lower/upper (revolute, prismatic)
  double lower = 0.0, upper = 0.0;
  std::string mimic_of;                       ///< master joint name, empty when not a mimic
  int mimic = -1;                             ///< index into KModel::joints of the master
  double multiplier = 1.0, offset = 0.0;      ///< q = multiplier * q_master + offset
  double effort = 0.0, velocity = 0.0;        ///< <limit effort, velocity> (0 when absent)
  int value_index = -1;                       ///< index into the joint value vector (-1: fixed)
};

/// One URDF link.
struct KLink {
  std::string name;
  int parent_joint = -1;  ///< index into KModel::joints (-1: the root)
  int geometry = -1;      ///< index into KModel::geometry (-1: no geometry)
  HandInertial inertial;  ///< the URDF <inertial> (present = false when absent)
};

/// A URDF kinematic tree with link geometry.
struct KModel {
  std::string urdf_path;
  std::string robot_name;
  std::vector<KLink> links;        ///< depth-first from the root (links[0]), parents first
  std::vector<KJoint> joints;      ///< joints[k] is the parent joint of some link
  std::vector<int> movable;        ///< joint indices of the non-fixed joints, value order
  std::vector<HandLink> geometry;  ///< links with geometry, depth-first order
  std::map<std::string, int> link_index, joint_index;
};

/// Thrown by load_urdf() when `wrist_link` cannot root a hand: no such link, or a joint of its
/// subtree mimics a joint above it.
struct BadWrist : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Reads the hand in the URDF at `urdf_path` and the geometry of its links. The hand is the
/// subtree of `wrist_link`, its root: the links above it (a robot's arm, a mount) and their joints
/// are ignored, their meshes not read. Mesh URIs are resolved relative to the URDF's directory, `package://`
/// ones through `package_paths`. Throws BadWrist, or FileError naming the URDF (malformed,
/// unsupported joint, unresolvable package URI) or the mesh and its link (missing or unreadable mesh).
KModel load_urdf(const std::string& urdf_path, const std::vector<std::string>& package_paths,
                 const std::string& wrist_link);

/// Closed-form triangle meshes of the URDF primitives, link frame, outward winding.
Mesh box_mesh(const Eigen::Vector3d& size, const std::string& name);
Mesh cylinder_mesh(double radius, double length, const std::string& name, int segments = 32);
Mesh sphere_mesh(double radius, const std::string& name, int subdivisions = 3);

/// A joint value as an affine function of one DOF: q = ratio * dof + offset.
struct Drive {
  int dof = -1;
  double ratio = 0.0;
  double offset = 0.0;
};

/// One per-link sample in its link frame.
struct LinkSample {
  int link = -1;  ///< index into geometry links
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
};

/// Area samples of every active link at one spacing, link frames.
struct AreaSamples {
  std::vector<int> link;  ///< geometry link index of each block
  std::vector<Points> points, normals;
};

/// Per-link sample of an active surface: see ConstellationMode::PerLink.
LinkSample per_link_sample(const Mesh& mesh, const std::vector<int>& faces);


}  // namespace hand_detail

struct Hand::Impl {
  std::string name;
  std::string spec_path;
  std::string wrist;
  int wrist_index = 0;  ///< index into model.links
  hand_detail::KModel model;
  std::vector<Dof> dofs;
  Eigen::Vector3d approach = Eigen::Vector3d::UnitZ();
  std::vector<hand_detail::Drive> drives;  ///< per joint value (model.movable order), mimics resolved
  std::vector<hand_detail::LinkSample> per_link;  ///< active links, links() order

  /// Area samples per spacing, computed on first use. At most kMaxCachedSpacings are kept.
  static constexpr std::size_t kMaxCachedSpacings = 8;
  mutable std::mutex cache_mutex;
  mutable std::map<double, std::shared_ptr<const hand_detail::AreaSamples>> area_cache;
  mutable std::vector<double> cache_order;  ///< spacings, oldest first

  /// Checks (and clamps) a DOF vector; throws std::invalid_argument as documented.
  Eigen::VectorXd checked_dofs(const Eigen::VectorXd& dofs, bool clamp) const;
  /// Joint values of a checked DOF vector.
  Eigen::VectorXd joint_values(const Eigen::VectorXd& checked) const;
  /// Pose of every model link in the root frame.
  std::vector<Pose> root_poses(const Eigen::VectorXd& joint_values) const;
  /// Area samples at a spacing (cached).
  std::shared_ptr<const hand_detail::AreaSamples> area_samples(double spacing) const;
};

}  // namespace pairgrasp
