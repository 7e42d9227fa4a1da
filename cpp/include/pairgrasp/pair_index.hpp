#pragma once
/// @file pair_index.hpp
/// All target pairs within d_max, their features, and a balanced AABB hierarchy over the
/// features for tolerance-box queries. Built once per target.
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
};

/// The target's pair features in a flat, balanced AABB hierarchy.
///
/// Only pairs whose two facets are both free are stored (all pairs when `free` is empty).
class PairIndex {
 public:
  /// points, normals: (N,3) facet centres and unit outward normals. free: (N) or empty.
  /// Throws std::invalid_argument for mismatched sizes, NaN, non-unit normals, d_max <= 0, and
  /// BudgetError when the pair count exceeds options.max_pairs (naming the facet count that fits).
  PairIndex(const Points& points, const Points& normals, const Mask& free = Mask(),
            const PairIndexOptions& options = {});

  std::size_t size() const;                 ///< stored pairs
  /// (M,2) facet indices of stored pairs, i < j.
  const Eigen::Matrix<std::int32_t, Eigen::Dynamic, 2, Eigen::RowMajor>& pairs() const;
  /// (M,3) features (d, phi, beta_ij + beta_ji) of stored pairs.
  const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>& features() const;
  /// Appends to `out` the index of every stored pair whose feature lies in the box
  /// |feature_k - center_k| <= tolerance_k for k = 0, 1, 2. Exactly the brute-force set.
  void query(const Eigen::Vector3d& center, const Eigen::Vector3d& tolerance,
             std::vector<std::uint32_t>& out) const;
  /// Same as query(), filled into a fresh vector.
  std::vector<std::uint32_t> query(const Eigen::Vector3d& center, const Eigen::Vector3d& tolerance) const;
  /// Bytes held by the index (pairs, features, tree).
  std::size_t nbytes() const;

  const Points& points() const;
  const Points& normals() const;
  const Mask& free() const;
  double d_max() const;
  /// Median nearest-neighbour spacing of the points, metres (a proxy for the facet size h).
  double spacing() const;

  struct Impl;
 private:
  std::shared_ptr<const Impl> impl_;
};

}  // namespace pairgrasp
