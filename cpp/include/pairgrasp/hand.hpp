#pragma once
/// @file hand.hpp
/// Articulated hands: a URDF (urdfdom) plus a hand spec (JSON) naming the wrist frame, the DOFs,
/// the active (contact) surface of each link and the approach direction.
///
/// Frames: every pose returned here is expressed in the **wrist frame** (the spec's
/// `wrist_link`), not the URDF root. `Hand::root_to_wrist()` gives the fixed offset between them.
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
  double lower = 0.0;            ///< lower limit (rad or m)
  double upper = 0.0;            ///< upper limit (rad or m)
  double step = 0.25;            ///< default sampling step (rad or m)
};

/// A link with geometry, in its own link frame.
struct HandLink {
  std::string name;
  Mesh mesh;                   ///< collision geometry (visual if none), link frame, metres
  std::vector<int> active_faces;  ///< faces of `mesh` that form the contact surface
  bool active() const { return !active_faces.empty(); }
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
  PerLink,  ///< one sample per active link (the paper: 7 for the Barrett hand)
  Area,     ///< evenly spread samples at a given spacing over every active surface
};

/// Options for Hand::load().
struct HandLoadOptions {
  /// Directories searched for `package://NAME/...` URIs: NAME is looked up as a sub-directory of
  /// each (and the directory holding the URDF is tried as the package itself).
  std::vector<std::string> package_paths;
};

/// A hand: kinematic tree, DOF map, link geometry and active surfaces.
class Hand {
 public:
  /// Loads the hand spec at `spec_path` (JSON) and the URDF it names. Throws FileError naming
  /// the spec, the URDF or the mesh at fault and the field.
  static Hand load(const std::string& spec_path, const HandLoadOptions& options = {});

  const std::string& name() const;
  const std::vector<Dof>& dofs() const;
  std::vector<std::string> dof_names() const;
  Eigen::VectorXd dof_lower() const;
  Eigen::VectorXd dof_upper() const;
  Eigen::VectorXd dof_step() const;
  /// Links with geometry, in a fixed order (the URDF's depth-first order from the root).
  const std::vector<HandLink>& links() const;
  /// Name of the wrist link (the frame poses are expressed in).
  const std::string& wrist_link() const;
  /// Approach direction in the wrist frame (unit): the direction the palm faces.
  const Eigen::Vector3d& approach() const;
  /// Pose of the wrist frame in the URDF root frame.
  Pose root_to_wrist() const;
  /// Names of every non-fixed URDF joint, in the order joint_values() uses.
  std::vector<std::string> joint_names() const;

  /// Values of every non-fixed joint (mimics applied) for a DOF vector.
  /// Throws std::invalid_argument for a wrong size, NaN, or a value outside the limits unless
  /// `clamp` is true (then values are clamped).
  Eigen::VectorXd joint_values(const Eigen::VectorXd& dofs, bool clamp = false) const;
  /// Pose of every link in the wrist frame, keyed by link name (every URDF link).
  std::map<std::string, Pose> link_transforms(const Eigen::VectorXd& dofs, bool clamp = false) const;
  /// Poses of links() in the wrist frame, in links() order.
  std::vector<Pose> link_poses(const Eigen::VectorXd& dofs, bool clamp = false) const;
  /// Active-surface samples at a DOF vector. `spacing` (m) is used by ConstellationMode::Area.
  Constellation constellation(const Eigen::VectorXd& dofs, ConstellationMode mode,
                              double spacing = 0.01, bool clamp = false) const;

  struct Impl;
 private:
  std::shared_ptr<const Impl> impl_;
};

}  // namespace pairgrasp
