#pragma once
/// @file planner.hpp
/// Planning from C++: a GraspPlanner holds everything built once per hand and target (the
/// parameters resolved from the hand and the target, the target's unit facets and pair index, the
/// aligner, the grasp checker). It is a handle: copies share the same immutable state, and every
/// const member may be called from several threads at once. One plan's search over it is a
/// GraspSearch (search.hpp); plan_samples() runs a list of DOF samples through one.
///
/// Frames: wrist poses map wrist coordinates to target coordinates (p_T = R·p_G + t). Lengths are
/// metres, angles radians.
#include <pairgrasp/aligner.hpp>
#include <pairgrasp/candidates.hpp>
#include <pairgrasp/collision.hpp>
#include <pairgrasp/free_surface.hpp>
#include <pairgrasp/hand.hpp>
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/pair_index.hpp>
#include <pairgrasp/types.hpp>

#include <cstddef>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace pairgrasp {

/// How constellations are chosen.
enum class ConstellationChoice {
  /// Per-link, but antipodal for a parallel jaw (two per-link samples facing each other along the
  /// line between them), and area for other hands whose per-link pairs fix no roll (every pair
  /// antipodal, or fewer than 3 samples).
  Auto,
  PerLink,    ///< one sample per active link (the paper)
  Area,       ///< samples spread over the active surfaces
  Antipodal,  ///< a parallel jaw's two pads aligned on the target's antipodal pairs (Aligner::align_antipodal())
};

/// Options of GraspPlanner: what is fixed once the target is indexed. An unset optional is derived
/// as documented per field.
struct PlannerOptions {
  /// Unit-facet edge h (m); unset: 5 mm, or 1/15 of the target's smallest extent if smaller, or
  /// coarser when the pair budget requires it (suggest_edge()).
  std::optional<double> edge;
  /// Largest stored pair distance (m); unset: the largest distance between two constellation
  /// samples over the hand's DOF range (corners and middles of every DOF), plus h.
  std::optional<double> d_max;
  std::size_t max_pairs = 20'000'000;  ///< pair budget of the index
  /// Pairs kept per cell of the feature space (PairIndexOptions::max_pairs_per_cell; 0: all): the
  /// pairs of a flat face, a sphere or two parallel faces share a few cells, and only about this many
  /// of each cell are stored and matched; a pose's votes count the kept pairs (docs/planner.md).
  std::size_t max_pairs_per_cell = 512;
  ConstellationChoice constellation = ConstellationChoice::Auto;
  /// Area-sample spacing (m); unset: the smallest of h·1.25^k giving at most max_area_samples at mid-range.
  std::optional<double> spacing;
  int max_area_samples = 24;
  std::optional<double> depth_tolerance;  ///< penetration tolerated (m); unset: h / 4
  double gap = 0.001;                     ///< contact gap (m)
  /// Largest back-off along the approach axis when settling (m), the default of every search
  /// (PlanOptions::backoff); unset: half the hand's reach (the largest distance of a per-link
  /// constellation sample from the wrist).
  std::optional<double> backoff;
  /// Cell edge of the checker's distance fields (m; CheckOptions::field_cell); unset: h / 5 but at
  /// least 1 mm (1 mm at the default 5 mm edge and on smaller targets; coarser when h is coarser).
  /// Unused where the checker has no fields (PlannerSetup::distance_fields).
  std::optional<double> field_cell;
  /// Memory budget of the target's distance fields (bytes), checked on an estimate before they
  /// are built (BudgetError past it).
  std::size_t max_field_bytes = std::size_t(2) << 30;
  /// Friction coefficient of the searches this planner serves (PlanOptions::mu may not exceed it).
  /// Free faces that cannot hold a contact of a force-closure grasp at this friction within the
  /// hand's contact span (graspable_faces() of graspable.hpp) are not indexed, and a target with
  /// none left is refused at once.
  double mu = 0.5;
  int threads = 0;  ///< 0: every core
};

/// The parameters a GraspPlanner resolved from the hand and the target (before the index is
/// built), so that a caller may check them first (e.g. the target's scale against d_max).
struct PlannerSetup {
  double edge = 0.0;   ///< unit-facet edge (m)
  double d_max = 0.0;  ///< largest stored pair distance (m)
  ConstellationMode mode = ConstellationMode::PerLink;
  bool antipodal = false;        ///< per-link constellations aligned by Aligner::align_antipodal() (a parallel jaw)
  double spacing = 0.0;          ///< area spacing (m; 0 for per-link constellations)
  double depth_tolerance = 0.0;  ///< m
  double backoff = 0.0;          ///< m
  double reach = 0.0;            ///< largest distance of a constellation sample from the wrist (m)
  double field_cell = 0.0;       ///< cell edge of the checker's distance fields (m)
  /// Whether the checker works on distance fields (CheckOptions::use_distance_field): yes for a
  /// per-link or area search, no for an antipodal one: a jaw's few hundred candidates are checked
  /// exactly in less time than the fields take to build (the collision flags are the same either
  /// way; depths are then exact instead of within (√3/2)·field_cell).
  bool distance_fields = true;
  /// Largest distance between two points of the active surfaces over the DOF range (the diagonal
  /// of their bounding box in the wrist frame, at the corners and middles of every DOF), plus h (m).
  double contact_span = 0.0;
  std::size_t free_faces = 0;       ///< free faces of the target
  /// Free faces that may hold a contact of a force-closure grasp (graspable_faces()): the index
  /// holds the pairs of their unit facets only.
  std::size_t graspable_faces = 0;
};

/// The largest distance between two per-link constellation samples of `hand` over its DOF range
/// (every DOF at its limits and middle), in metres: how far apart the hand's contacts can be, and
/// the derived d_max less the unit-facet edge in per-link mode.
double hand_span(const Hand& hand);

/// The power of ten that brings the largest extent of `target` nearest (in ratio) to `hand_span`
/// metres: 0.001 for a hand-sized object in millimetres, 1 for one in metres; 1 for an empty or flat mesh.
double suggest_target_scale(const Mesh& target, double hand_span);

/// Throws std::invalid_argument ("<target source>: ... is the mesh in millimetres? ... --scale 0.001")
/// when `target` is far too large or too small for a hand whose samples span `hand_span` metres:
/// every extent above 50 spans, or the largest below 1/200 of one. The usual sign of a mesh in
/// millimetres read as metres, or of a scale applied twice. The message names the scale that fixes
/// it (suggest_target_scale()) and the size the target then has.
void check_target_scale(const Mesh& target, double hand_span);

/// The finest unit-facet edge the planner derives for `target` (m): 5 mm, or a fifteenth of its
/// smallest extent when that is less (5 mm for a flat or empty mesh). A derived edge starts here and
/// only grows (the pair budget), so a quarter of it bounds the derived depth tolerance from below:
/// the error a simplification of the target may make.
double finest_edge(const Mesh& target);

/// Throws std::invalid_argument naming the first bad field of `options` (a length that is not finite
/// or not positive, a count below its least value).
void validate(const PlannerOptions& options);

/// Resolves PlannerOptions for a hand and a target (see each option), checking the target's scale
/// against d_max (check_target_scale()) and its free surface against the hand's contact span
/// (graspable_faces() at PlannerOptions::mu) before anything large is computed. Throws
/// std::invalid_argument for bad options (naming them), a target at the wrong scale, a free surface
/// no part of which can hold a force-closure grasp (naming the cone its normals fit in) or a hand
/// whose active surfaces give no two distinct samples.
PlannerSetup resolve_planner(const Hand& hand, const Mesh& target, const Mask& free, const PlannerOptions& options);

/// Per-DOF sample values: lower, lower + step, ..., and upper (a last, shorter step when the range is
/// not a multiple of the step). A DOF with lower == upper or step 0 has one value.
std::vector<std::vector<double>> dof_axes(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                                          const Eigen::VectorXd& steps);

/// Every sample of the grid of dof_axes() (the Cartesian product, the last DOF varying fastest).
std::vector<Eigen::VectorXd> dof_grid(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                                      const Eigen::VectorXd& steps);

/// What surrounds the target, in its frame: what covers its surface and what the hand must not touch.
struct Scene {
  /// Paint, regions, occluders, viewpoints and the support plane: the free surface.
  Occlusion occlusion;
  /// Meshes the hand must not touch (a table given as a mesh, a holder). A support plane is added
  /// as one more ("support": support_box() with a margin of twice the hand's reach plus the
  /// largest back-off), and occluders are not obstacles unless listed here too. Without a support
  /// plane, an obstacle the target stands on (SupportPlane::under(), within occlusion.distance) is
  /// the support settling lifts the hand out of (CheckOptions::support).
  std::vector<Obstacle> obstacles;
};

/// Everything built once per hand and target.
class GraspPlanner {
 public:
  /// Resolves the options, finds the free surface (free_surface() at half the unit-facet edge: the
  /// edge given, else 5 mm or 1/15 of the target's smallest extent), tessellates and indexes it,
  /// and builds the aligner and the grasp checker (the scene's obstacles and support). Throws
  /// std::invalid_argument for bad options or scene fields (named as in free_surface()),
  /// BudgetError when the pair budget cannot be met or the checker's distance fields would take
  /// more than max_field_bytes (estimate_field_bytes(), before anything large is built).
  GraspPlanner(const Hand& hand, const Mesh& target, const Scene& scene, const PlannerOptions& options = {});
  /// A scene of a paint mask (per face; empty: all free) and obstacles.
  GraspPlanner(const Hand& hand, const Mesh& target, const Mask& free = Mask(),
               const std::vector<Obstacle>& obstacles = {}, const PlannerOptions& options = {});

  const Hand& hand() const;
  /// The target planned on: the given one with faces split where the free surface changes
  /// (free_surface().mesh; the given mesh itself when no mark divides a face).
  const Mesh& target() const;
  /// Per face of target(): true = free.
  const Mask& free() const;
  /// The free surface (the refined target, its mask, each face's source face).
  const FreeSurface& free_surface() const;
  /// The obstacles the hand is checked against (the scene's, then the support's box).
  const std::vector<Obstacle>& obstacles() const;
  const PlannerSetup& setup() const;
  const PlannerOptions& options() const;
  const TargetIndex& target_index() const;
  const Aligner& aligner() const;
  const GraspChecker& checker() const;
  /// Torque reference of epsilon: the target's centre of mass and largest vertex distance from it.
  const TorqueReference& reference() const;
  /// Seconds spent in the constructor (index, aligner, checker and its distance fields).
  double setup_seconds() const;

  /// Per-DOF sampling step: `step` (rad) for angular DOFs (<= 0: the hand's), the hand's for linear ones.
  Eigen::VectorXd steps(double step = 0.0) const;
  /// The constellation aligned for a DOF sample (the resolved mode and spacing).
  Constellation constellation(const Eigen::VectorXd& dofs) const;
  /// Aligns each sample's constellation (all threads, one sample per task); result k belongs to
  /// samples[k], best pose first, at most `max_poses` poses (0: the aligner's, 10); a parallel
  /// jaw's (antipodal) at most `max_poses` grasp lines of `antipodal_rolls` poses each.
  std::vector<AlignResult> align(const std::vector<Eigen::VectorXd>& samples, int max_poses = 0) const;
  /// Early-rejection score of each sample (all threads): the fraction of its constellation's
  /// pairs whose feature (normals flipped, d <= d_max) matches at least one stored target pair
  /// within the aligner's feature tolerance (0 for fewer than 2 points). A sample whose fraction
  /// is small cannot collect the votes of a good alignment (the paper's Figure 7). For a parallel
  /// jaw (antipodal): 1 when it can close on some antipodal pair (Aligner::antipodal_count()), else 0.
  std::vector<double> match_fractions(const std::vector<Eigen::VectorXd>& samples) const;

 private:
  struct State;
  std::shared_ptr<const State> state_;
};

}  // namespace pairgrasp
