#pragma once
/// @file hand.hpp
/// Articulated hands: a URDF (urdfdom) plus a hand spec (JSON) naming the wrist frame, the DOFs,
/// the active (contact) surface of each link and the approach direction.
///
/// Frames: every pose returned here is expressed in the **wrist frame** (the spec's
/// `wrist_link`), which may be any link of the URDF: the hand is the wrist's subtree, so a robot's
/// whole URDF can supply its hand; the links above the wrist (an arm, a mount) and their joints
/// are ignored and their meshes not read.
///
/// The spec format is documented in models/README.md ("Hand spec format").
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/types.hpp>

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace pairgrasp {

/// One joint driven by a DOF: q_joint = ratio * q_dof + offset (radians or metres).
struct DofJoint {
  std::string joint;
  double ratio = 1.0;
  double offset = 0.0;
};

/// A degree of freedom of the hand as the planner samples it.
struct Dof {
  std::string name;
  std::vector<DofJoint> joints;  ///< joints it drives (mimic joints of these follow too)
  double lower = 0.0;            ///< lower limit (rad, or m when `linear`)
  double upper = 0.0;            ///< upper limit (rad, or m when `linear`)
  double step = 0.25;            ///< default sampling step (rad, or m when `linear`)
  bool linear = false;           ///< drives prismatic joints: values in metres, else radians
};

/// A link with geometry, in its own link frame.
struct HandLink {
  std::string name;
  Mesh mesh;                   ///< collision geometry (visual if none), link frame, metres
  std::vector<int> active_faces;  ///< faces of `mesh` that form the contact surface (ascending)
  bool active() const { return !active_faces.empty(); }
};

/// A URDF joint of the hand's kinematic tree (fixed joints included), as read from the URDF.
/// The child link's frame is the joint frame: at joint value q it is `origin` followed by a
/// rotation of q about `axis` (revolute, continuous) or a translation of q along it (prismatic).
struct HandJoint {
  enum class Type { Fixed, Revolute, Continuous, Prismatic };
  std::string name;
  Type type = Type::Fixed;
  std::string parent_link;  ///< URDF parent link
  std::string child_link;   ///< URDF child link
  Pose origin = Pose::Identity();  ///< joint (child link) frame in the parent link frame at q = 0, metres
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();  ///< unit, joint frame (unused when fixed)
  bool limited = false;     ///< has position limits (revolute, prismatic)
  double lower = 0.0;       ///< lower limit (rad, or m when prismatic)
  double upper = 0.0;       ///< upper limit (rad, or m when prismatic)
  double effort = 0.0;      ///< URDF <limit effort>: N·m (revolute, continuous) or N (prismatic); 0 when absent
  double velocity = 0.0;    ///< URDF <limit velocity>: rad/s or m/s; 0 when absent
  std::string mimic_joint;  ///< the joint it mimics (empty when it is not a mimic joint)
  double multiplier = 1.0;  ///< mimic: q = multiplier * q_mimicked + offset
  double offset = 0.0;      ///< mimic offset (rad or m)
};

/// A link's URDF <inertial>: mass (kg) and inertia tensor (kg·m², about the centre of mass, in
/// the inertial frame), the inertial frame given in the link frame (its origin is the centre of
/// mass, metres).
struct HandInertial {
  bool present = false;  ///< false when the URDF gives no <inertial> for the link
  double mass = 0.0;
  Pose frame = Pose::Identity();
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
};

/// Samples of the active surface at one DOF vector, in the wrist frame.
struct Constellation {
  Points points;               ///< (P,3) metres
  Points normals;              ///< (P,3) unit, pointing out of the finger surface (not flipped)
  std::vector<int> link;       ///< index into Hand::links() for each sample
  std::vector<std::string> link_names;  ///< name of the link of each sample
};

/// How constellation samples are placed.
enum class ConstellationMode {
  /// One sample per active link (the paper: 7 for the Barrett hand). The sample is the point
  /// of the link's active surface nearest to the area-weighted centroid of its active faces
  /// (the centroid itself on a flat surface, a point on the surface when it is curved), with
  /// the normalised area-weighted mean of the active faces' normals (the normal of the face
  /// holding the point if that mean vanishes, e.g. on a closed tube).
  PerLink,
  /// Evenly spread samples at a given spacing over every active surface: the unit facets of
  /// tessellate(active sub-mesh, spacing), centres and normals. Computed once per link and
  /// spacing in the link frame, cached, then transformed.
  Area,
};

/// Options for Hand::load().
struct HandLoadOptions {
  /// Directories searched for `package://NAME/REST` mesh URIs, before the spec's own
  /// "package_paths" (which are relative to the spec file). For each directory D in order,
  /// D/NAME/REST is tried, then D/REST when D itself is named NAME. Relative entries here are
  /// taken from the current directory.
  std::vector<std::string> package_paths;
};

/// A hand: kinematic tree, DOF map, link geometry and active surfaces.
///
/// Immutable after load() and safe to use from several threads at once (the Area-mode sample
/// cache is guarded). Copies share the loaded model.
class Hand {
 public:
  /// Loads the hand spec at `spec_path` (JSON) and the URDF it names. Throws FileError naming
  /// the spec, the URDF or the mesh at fault and the field (e.g. "dofs[2].joints[0].joint: no
  /// joint 'x' in bh.urdf").
  static Hand load(const std::string& spec_path, const HandLoadOptions& options = {});

  /// The spec's "name" (the URDF robot name when the spec has none).
  const std::string& name() const;
  /// The spec file this hand was loaded from, and the URDF it names.
  const std::string& spec_path() const;
  const std::string& urdf_path() const;
  const std::vector<Dof>& dofs() const;
  std::vector<std::string> dof_names() const;
  /// Limits and default sampling steps of the DOFs (rad, or m for linear DOFs).
  Eigen::VectorXd dof_lower() const;
  Eigen::VectorXd dof_upper() const;
  Eigen::VectorXd dof_step() const;
  /// Links with geometry, in a fixed order: depth-first from the wrist link, children in the
  /// order their joints appear in the URDF file.
  const std::vector<HandLink>& links() const;
  /// Index of a link in links(), or -1 when it has no geometry or does not exist.
  int link_index(const std::string& link_name) const;
  /// Every link of the hand (the wrist link's subtree, with or without geometry), in the same
  /// depth-first order.
  std::vector<std::string> link_names() const;
  /// The URDF joints, fixed ones included, depth-first from the root like link_names() (the
  /// parent joint of every link but the root, in that link's order).
  std::vector<HandJoint> joints() const;
  /// The URDF <inertial> of a link (present = false when it has none). Throws
  /// std::invalid_argument for an unknown link name.
  HandInertial inertial(const std::string& link_name) const;
  /// Name of the wrist link (the frame poses are expressed in).
  const std::string& wrist_link() const;
  /// Approach direction in the wrist frame (unit): the direction the palm faces.
  const Eigen::Vector3d& approach() const;
  /// Identity: the hand is rooted at its wrist link (the wrist's subtree).
  [[deprecated("the hand is rooted at its wrist link, so this is always the identity")]] Pose root_to_wrist() const;
  /// Names of every non-fixed URDF joint (mimic joints included), in the order joint_values()
  /// uses: depth-first from the root like link_names().
  std::vector<std::string> joint_names() const;

  /// Values of every non-fixed joint (mimics applied) for a DOF vector (rad or m).
  /// Throws std::invalid_argument for a wrong size, a non-finite value, or a value outside its
  /// DOF's limits by more than 1e-9 (the message names the DOF and its limits) unless `clamp`
  /// is true (then values are clamped into the limits; non-finite values still throw).
  Eigen::VectorXd joint_values(const Eigen::VectorXd& dofs, bool clamp = false) const;
  /// Pose of every URDF link in the wrist frame, keyed by link name. Errors as joint_values().
  std::map<std::string, Pose> link_transforms(const Eigen::VectorXd& dofs, bool clamp = false) const;
  /// Poses of links() in the wrist frame, in links() order. Errors as joint_values().
  std::vector<Pose> link_poses(const Eigen::VectorXd& dofs, bool clamp = false) const;
  /// Active-surface samples at a DOF vector, in the wrist frame, ordered by link (links()
  /// order). `spacing` (m, positive and finite) is used by ConstellationMode::Area; a spacing
  /// so small that the samples would exceed tessellate()'s facet bound throws
  /// std::invalid_argument naming "spacing". Errors as joint_values() for `dofs`.
  Constellation constellation(const Eigen::VectorXd& dofs, ConstellationMode mode,
                              double spacing = 0.01, bool clamp = false) const;

 private:
  struct Impl;  // defined in the library's sources
  explicit Hand(std::shared_ptr<const Impl> impl);
  std::shared_ptr<const Impl> impl_;
};

}  // namespace pairgrasp
