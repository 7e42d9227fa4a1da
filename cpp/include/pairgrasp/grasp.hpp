#pragma once
/// @file grasp.hpp
/// Closing the fingers onto contact (GraspIt's "auto grasp") and the contacts of a grasp, on top
/// of a GraspChecker (which holds the hand, the target, its free mask and the obstacles).
///
/// Frames: the wrist pose maps wrist coordinates to target coordinates (p_T = R·p_G + t); every
/// point returned is in the target frame. Lengths are metres, DOF values radians (metres for
/// linear DOFs).
#include <pairgrasp/collision.hpp>
#include <pairgrasp/hand.hpp>
#include <pairgrasp/types.hpp>

#include <string>
#include <vector>

namespace pairgrasp {

/// Why a DOF stopped closing.
enum class StopReason {
  Contact,  ///< the active surface of one of its links came within the contact gap of the target or an obstacle
  Limit,    ///< it reached its joint limit without touching
  Blocked,  ///< a non-active part of one of its links touched first, or its links penetrate at the start
  Fixed,    ///< not a closing DOF (direction 0): left where it was
};

/// "contact", "limit", "blocked" or "fixed".
const char* to_string(StopReason reason);

/// Which way each DOF closes: +1 (increasing it closes), -1 (decreasing it closes) or 0 (it does
/// not close the hand, e.g. the Barrett spread).
///
/// Rule (no spec field is needed): a DOF closes in the direction that moves the active surfaces
/// of the links it drives along their own outward normals, i.e. towards an object held between
/// them. At `dofs` each active face's centroid velocity v (finite difference of the forward
/// kinematics) is compared with the face's outward normal n; the area-weighted score
/// Σ A·(v·n) / Σ A·|v| is in [-1, 1]. |score| >= 0.5 gives the direction sign(score); smaller
/// scores (surfaces sliding sideways, as under the Barrett spread) give 0, as do DOFs that drive
/// no active face. Throws std::invalid_argument for a bad DOF vector ("dofs: ...").
Eigen::VectorXi closing_directions(const Hand& hand, const Eigen::VectorXd& dofs);

/// Options of close_fingers().
struct CloseOptions {
  /// Per-DOF direction (+1, -1, 0), overriding closing_directions(); empty: inferred.
  Eigen::VectorXi directions;
  /// Iterations allowed per DOF (each is a few FCL distance queries). A DOF still moving after
  /// them stops with StopReason::Blocked.
  int max_iterations = 2000;
  /// false: skip what only reports: the check at the starting DOFs (`start`, `start_penetrating`
  /// left unset) and, with distance fields, the exact clearance of a DOF that stopped short of
  /// contact (its clearance is then the lower bound the closing stopped with).
  bool measure = true;
};

/// Result of close_fingers().
struct CloseResult {
  Eigen::VectorXd dofs;             ///< the closed DOF vector
  Eigen::VectorXi directions;       ///< the direction used for each DOF
  std::vector<StopReason> reasons;  ///< why each DOF stopped
  /// Distance (m) from the links each DOF drives to the target and obstacles where it stopped
  /// (<= contact gap on contact; inf for Fixed DOFs or links with nothing around).
  Eigen::VectorXd clearance;
  bool start_penetrating = false;   ///< the starting pose was already pruned (penetration or obstacle)
  CheckResult start;                ///< check at the starting DOFs
  CheckResult check;                ///< check at the closed DOFs
  int iterations = 0;               ///< distance evaluations used in total
};

/// Closes each closing DOF in turn (index order) from `dofs` until its active surface is within
/// the contact gap of the target (or an obstacle) or it reaches its limit.
///
/// Each DOF moves the links downstream of its joints. Motion is by conservative advancement: the
/// distance d from those links (every face) to the target and obstacles (FCL; with distance
/// fields a lower bound of it from the target's field while it is beyond gap/2, the exact
/// distance below) and a bound v on the speed of their vertices per unit of the DOF give a step
/// (d − gap/4)/(1.5·v) that cannot reach the surface; a step that still ends intersecting is
/// bisected back. So a finger never crosses a surface on the way and stops within half the
/// contact gap of it, where the active-surface samples of a face lying parallel to the target
/// register as contacts (find_contacts() takes those within the gap). A DOF whose links
/// penetrate beyond the tolerance (or touch an obstacle) at the start does not move (Blocked,
/// and start_penetrating). Self-collision of the hand is not considered.
/// Throws std::invalid_argument for a bad wrist ("wrist: ..."), DOF vector ("dofs: ...") or
/// directions ("directions: ...").
CloseResult close_fingers(const GraspChecker& checker, const Pose& wrist, const Eigen::VectorXd& dofs,
                          const CloseOptions& options = {});

/// Contacts of a grasp with the target, in the target frame; row k of every block is contact k.
struct Contacts {
  Points points;              ///< (C,3) points of the hand's active surfaces, metres
  Points target_points;       ///< (C,3) the closest target surface points, metres
  Points normals;             ///< (C,3) unit outward normals of the target at those points (face normals)
  Eigen::VectorXd distances;  ///< (C) signed gaps, metres: > 0 apart, < 0 inside the target
  Eigen::VectorXi faces;      ///< (C) target faces holding target_points
  std::vector<int> links;     ///< (C) indices into Hand::links()
  std::vector<std::string> link_names;  ///< (C) link names
  int occluded_count = 0;     ///< contacts found on occluded faces (thinned the same way; not listed)
};

/// How each closing DOF's push on the object is met (closing_push()). Both are the least over
/// the closing DOFs (closing_directions()) that move a contact, in [-1, 1]; -1 when none does.
struct ClosingPush {
  /// How squarely the DOF's push is pushed back. Its push is the sum of the inward normals
  /// (−normals) of the contacts on the links it moves, each weighted by how far its closing motion
  /// there drives into the surface (max(0, cosine between motion and inward normal)). Its opposition
  /// is the larger of how far its own contacts' pushes cancel (1 − |push| / Σ weights: 1 for a
  /// parallel jaw's two pads, which one DOF moves) and the largest cosine between the reversed push
  /// and the inward normal of a contact it does not move (the palm, the other fingers): 1 when some
  /// contact pushes straight back, 0 when only friction can hold the push (the Barrett spread at π,
  /// fingers 1 and 2 pinching across while finger 3 pushes between them).
  double opposition = -1.0;
  /// How squarely the DOF closes into the surface: the largest cosine between a contact's closing
  /// motion and its inward normal (1: into it; near 0: sliding along it, pushing the object aside).
  double drive = -1.0;
};

/// The ClosingPush of a grasp's contacts (target frame) at (wrist, dofs): motion by forward
/// kinematics (finite differences). In the physics check, grasps whose fingers push the object
/// out while closing or once the table is gone score low (docs/physics.md). Throws
/// std::invalid_argument for a bad DOF vector ("dofs: ..."), a wrist that is not rigid
/// ("wrist_pose: ..."), contacts whose sizes or link indices do not fit the hand ("contacts: ...")
/// and non-finite points ("points: ...").
ClosingPush closing_push(const Hand& hand, const Pose& wrist, const Eigen::VectorXd& dofs, const Contacts& contacts);

/// Options of closing_friction().
struct ClosingFrictionOptions {
  double mu_max = 2.0;       ///< the largest friction coefficient tried
  int edges = 8;             ///< edges of each friction pyramid (wrenches.hpp's convention)
  double tolerance = 1e-3;   ///< accuracy of the answer (bisection)
};

/// The least friction coefficient at which the closing DOFs, each pushing with its stall torque,
/// are balanced by contact forces at `contacts` (target frame, at (wrist, dofs)), with no load on
/// the object. Each closing DOF (closing_directions()) that moves a contact pushes with
/// |ratio| * effort of its first joint (the physics check's actuator; all equal when one has no
/// effort): the work it does per unit of closing equals that of the contact forces on the contacts
/// it moves. A DOF that does not close the hand (the Barrett spread) and a link no DOF moves (the
/// palm) push back with whatever force balance needs. The forces lie in the friction pyramids and
/// add up to no net force and no net torque about `center` (metres, the target's centre of mass).
/// Returns a value in [0, mu_max] (0: the normal forces alone balance), +infinity when mu_max does
/// not balance them (a finger pushing the object away alone), NaN when no closing DOF moves a
/// contact. Each trial coefficient is a non-negative least-squares feasibility test. Throws
/// std::invalid_argument for a bad DOF vector ("dofs: ..."), a wrist that is not rigid, a link
/// index out of range, non-finite points, normals or center, and bad options (naming the field).
double closing_friction(const Hand& hand, const Pose& wrist, const Eigen::VectorXd& dofs, const Contacts& contacts,
                        const Eigen::Vector3d& center, const ClosingFrictionOptions& options = {});

/// The contacts of the hand at (wrist, dofs): the samples of every link's active faces (spacing
/// CheckOptions::contact_spacing, independent of any constellation) whose signed distance to the
/// target lies in [−max(depth_tolerance, contact_gap), contact_gap], on free faces only (per the
/// checker's free mask; those on occluded faces are only counted). So that one flat patch does
/// not yield hundreds of near-duplicates, they are thinned to one per cube of edge
/// CheckOptions::contact_cell of a grid in the target frame, per link: the one closest to the
/// surface (smallest |distance|). Order: by link, then by grid cell. Throws as close_fingers().
Contacts find_contacts(const GraspChecker& checker, const Pose& wrist, const Eigen::VectorXd& dofs);

}  // namespace pairgrasp
