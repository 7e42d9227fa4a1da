#pragma once
/// @file pair_index.hpp
/// All target pairs within d_max, their features, and a balanced AABB hierarchy over the
/// features for tolerance-box queries. Built once per target.
#include <pairgrasp/facets.hpp>
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/types.hpp>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace pairgrasp {

/// Options for PairIndex.
struct PairIndexOptions {
  double d_max = 0.2;                 ///< store pairs with d <= d_max (metres)
  std::size_t max_pairs = 100'000'000; ///< pair budget: more pairs are refused with BudgetError
  int threads = 0;                    ///< 0: all cores
  /// Store only pairs whose unit normals' dot product n_i.n_j is at most this (1: every pair).
  /// A parallel jaw's antipodal alignment needs only opposed pairs (-cos(2 cone)): a few per cent
  /// of them. The budget counts the pairs stored.
  double max_normal_dot = 1.0;
  /// Thinning of dense feature cells (0: every pair is stored). The pairs are binned by feature in
  /// cells of `cell`; a cell holding c > max_pairs_per_cell pairs keeps about c / w of them,
  /// w = ceil(c / max_pairs_per_cell), chosen by a hash of (i, j) (so the same pairs whatever the
  /// threads), and each kept pair stands for w (PairIndex::weight()). On a flat face, a sphere or two
  /// parallel faces every pair at one distance has the same feature: such cells hold thousands of
  /// pairs that place the gripper at equivalent poses, and a gripper pair's query returns them all.
  std::size_t max_pairs_per_cell = 0;
  /// The thinning's cell (d metres, n_i.n_j, beta_ij + beta_ji). Zero: (0.5 h, 0.1, 0.1), the
  /// Aligner's default tolerance box, with h the points' spacing().
  Eigen::Vector3d cell = Eigen::Vector3d::Zero();
};

/// The target's pair features in a flat, balanced AABB hierarchy.
///
/// Only pairs whose two facets are both free are stored (all pairs when `free` is empty).
/// Pairs are found with a uniform grid of cell d_max (no all-pairs distance test), counted
/// before anything is stored (the budget), and kept compactly: 2 int32 indices, 3 float32
/// features and 4 int16 angle terms (pair_geometry(), for the Aligner's pre-filter) per pair,
/// 28 bytes. The hierarchy is a complete binary tree in heap order (children of node k
/// are 2k+1 and 2k+2) whose every level splits its range of pairs at the median along the axis
/// of largest extent (extents measured relative to the root box, so metres and cosines weigh
/// alike); leaves hold 16 to 32 pairs (fewer only when there are fewer); a node is one float32 box
/// (24 bytes). With PairIndexOptions::max_pairs_per_cell, dense feature cells are thinned, and
/// weight() tells how many pairs each stored one stands for. pairs() and
/// features() are stored in the tree's leaf order, so a subtree is a contiguous range.
class PairIndex {
 public:
  /// points, normals: (N,3) facet centres and unit outward normals. free: (N) or empty.
  /// Throws std::invalid_argument for mismatched sizes, NaN, non-unit normals, d_max <= 0, and
  /// BudgetError when the pair count exceeds options.max_pairs (naming the facet count that fits).
  PairIndex(const Points& points, const Points& normals, const Mask& free = Mask(),
            const PairIndexOptions& options = {});

  std::size_t size() const;                 ///< stored pairs
  /// Pairs with d <= d_max (and within max_normal_dot) before thinning: the count the budget
  /// checks, equal to size() without thinning.
  std::size_t pairs_found() const;
  /// The number of pairs stored pair k stands for: 1, or the thinning weight of its feature cell
  /// (see PairIndexOptions::max_pairs_per_cell). The weights of the stored pairs sum to about
  /// pairs_found(). k < size().
  std::uint32_t weight(std::size_t k) const;
  /// The thinning's cell (zero without thinning) and cap.
  Eigen::Vector3d thin_cell() const;
  std::size_t max_pairs_per_cell() const;
  /// (M,2) facet indices of stored pairs, i < j.
  const Eigen::Matrix<std::int32_t, Eigen::Dynamic, 2, Eigen::RowMajor>& pairs() const;
  /// (M,3) features (d, phi, beta_ij + beta_ji) of stored pairs.
  const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>& features() const;
  /// Scale of pair_geometry(): a stored angle v stands for v * pi / kGeometryScale radians, a
  /// stored triple product v for v / kGeometryScale.
  static constexpr int kGeometryScale = 32767;
  /// (M,4) int16 per stored pair (i, j), with u = (p_j - p_i) / |p_j - p_i|, rounded to the
  /// scale (error at most 0.5 / kGeometryScale of the range, plus rounding of the double
  /// computation): the angles (radians in [0, pi]) between n_i and n_j, n_i and u, n_j and u,
  /// and the triple product (n_i x n_j).u in [-1, 1] (the handedness of the pair). The last
  /// three are zero for coincident points. The Aligner rejects correspondences with them before
  /// the pose solve (see aligner.hpp).
  const Eigen::Matrix<std::int16_t, Eigen::Dynamic, 4, Eigen::RowMajor>& pair_geometry() const;
  /// Appends to `out` the index of every stored pair whose feature lies in the box
  /// |feature_k - center_k| <= tolerance_k for k = 0, 1, 2, in increasing order. The test is
  /// made on the stored float32 features promoted to double, exactly as a brute-force scan
  /// (`abs(double(f) - c) <= tol`) makes it, so the set is exactly the brute-force set.
  /// Throws std::invalid_argument for a non-finite center or a negative or NaN tolerance.
  void query(const Eigen::Vector3d& center, const Eigen::Vector3d& tolerance,
             std::vector<std::uint32_t>& out) const;
  /// Same as query(), filled into a fresh vector.
  std::vector<std::uint32_t> query(const Eigen::Vector3d& center, const Eigen::Vector3d& tolerance) const;
  /// The number of stored pairs query() would return, without listing them (a subtree wholly
  /// inside the box counts in O(1)). Same errors as query().
  std::size_t count(const Eigen::Vector3d& center, const Eigen::Vector3d& tolerance) const;
  /// Bytes held by the index (pairs, features, tree, thinning weights per cell).
  std::size_t nbytes() const;

  const Points& points() const;
  const Points& normals() const;
  const Mask& free() const;
  double d_max() const;
  /// Median nearest-neighbour spacing of the points, metres (a proxy for the facet size h).
  double spacing() const;
  /// Depth of the hierarchy's leaves (0: the root is the only node).
  int depth() const;
  /// (nodes, 6) float32 boxes of the hierarchy in heap order: min d, phi, beta then max.
  const std::vector<float>& node_boxes() const;

 private:
  struct Impl;  // defined in the library's sources
  std::shared_ptr<const Impl> impl_;
};

/// Number of pairs i < j with |p_i - p_j| <= d_max whose two points are free (all points when
/// `free` is empty): the count PairIndex would store. Grid-based, O(N + pairs).
/// Throws std::invalid_argument for bad sizes, NaN or d_max <= 0.
std::size_t count_pairs(const Points& points, double d_max, const Mask& free = Mask(), int threads = 0);

/// The finest facet edge (metres, to within a few per cent) at which tessellate(mesh, edge,
/// free_faces) gives no more than `max_pairs` stored pairs with d <= d_max. The pair count is
/// first estimated from the area (facets are about (sqrt(3)/2) edge^2 each and the fraction of
/// facet pairs within d_max is measured on a coarse tessellation), then checked by tessellating
/// and counting, refining the edge until the count fits. A positive `min_edge` (metres) is the
/// finest edge wanted: it is counted first and returned at once when its pairs fit (unless the
/// estimate at it is over 1.5 times the budget: then it cannot fit, and is not counted), and the
/// result is never finer than it.
/// Throws std::invalid_argument for d_max <= 0, max_pairs == 0, a negative or non-finite min_edge
/// or a mask of the wrong size.
double suggest_edge(const Mesh& mesh, double d_max, std::size_t max_pairs, const Mask& free_faces = Mask(),
                    double min_edge = 0.0);

/// A target ready for alignment: its unit facets and their pair index.
struct TargetIndex {
  UnitFacets facets;
  PairIndex index;
};

/// The refusal build_target_index() makes before tessellating, for callers that size other work
/// by the same edge (the planner builds its checker beside the index): throws build_target_index()'s
/// BudgetError when the pairs at `edge` (metres) are estimated far over options.max_pairs, and its
/// std::invalid_argument for the arguments it rejects. Returns normally otherwise, and for edge 0
/// (suggested); the exact count is left to build_target_index().
void check_pair_estimate(const Mesh& mesh, double edge, const Mask& free_faces = Mask(),
                         const PairIndexOptions& options = {});

/// Tessellates `mesh` at `edge` (metres; 0: suggest_edge(mesh, options.d_max, options.max_pairs))
/// and indexes the pairs of its free facets.
///
/// Memory is bounded by the pair budget: the pairs at `edge` are first estimated (as
/// suggest_edge() does) and, far over the budget, refused before the fine tessellation is made;
/// otherwise they are counted exactly before any is stored. Either way the refusal is a
/// BudgetError ("max_pairs: at a facet edge of 0.001 m the target gives about 1.2e+09 pairs ...;
/// a facet edge of 0.004213 m fits ...") naming an edge at which the pairs fit the budget.
/// Throws std::invalid_argument for a negative or non-finite edge, d_max <= 0 or max_pairs == 0.
TargetIndex build_target_index(const Mesh& mesh, double edge, const Mask& free_faces = Mask(),
                               const PairIndexOptions& options = {});

}  // namespace pairgrasp
