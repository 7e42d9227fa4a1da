#pragma once
// Internal: the fixed-capacity vote accumulators of the Aligner (hashed bins over a grid) and the
// greedy merging of bins into clusters. See aligner.hpp for how they are used.
#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace pairgrasp::detail {

/// Bins of a D-dimensional grid, hashed, holding at most `capacity` bins. Each bin sums its
/// entries' weighted values. Memory is fixed by min(capacity, expected entries) at construction;
/// an entry for a new cell when every bin is taken is dropped and counted (never a reallocation).
template <int D>
class HashedBins {
 public:
  using Cell = std::array<std::int32_t, D>;
  using Value = Eigen::Matrix<double, D, 1>;
  struct Bin {
    Cell cell{};
    double weight = 0.0;
    Value sum = Value::Zero();  // sum of weight * value
    std::uint32_t count = 0;
  };

  HashedBins(std::size_t capacity, std::size_t expected_entries);

  /// Adds weight * value to the bin of `cell`. Returns the bin's index, or -1 when the cell has
  /// no bin and `capacity` bins are taken (the entry is dropped and counted).
  std::int32_t add(const Cell& cell, const Value& value, double weight);
  /// Index of the bin of `cell`, or -1.
  std::int32_t find(const Cell& cell) const;

  const std::vector<Bin>& bins() const { return bins_; }
  std::size_t capacity() const { return capacity_; }
  bool saturated() const { return dropped_entries_ > 0; }
  std::size_t dropped_entries() const { return dropped_entries_; }
  double dropped_weight() const { return dropped_weight_; }

 private:
  std::size_t slot_of(const Cell& cell) const;
  std::vector<std::int32_t> table_;  // open addressing, linear probing: bin index or -1
  std::vector<Bin> bins_;
  std::size_t capacity_;
  std::size_t mask_;
  std::size_t dropped_entries_ = 0;
  double dropped_weight_ = 0.0;
};

/// Grid cell of a canonical unit quaternion (w >= 0) for a cell edge `cell` (quaternion units).
std::array<std::int32_t, 4> quaternion_cell(const Eigen::Quaterniond& q, double cell);
/// Grid cell of a point for a cell edge `cell` (metres).
std::array<std::int32_t, 3> position_cell(const Eigen::Vector3d& p, double cell);
/// The unit quaternion q or -q whose first non-zero coefficient of (w, x, y, z) is positive.
Eigen::Quaterniond canonical_quaternion(Eigen::Quaterniond q);

/// A set of merged bins.
struct Cluster {
  std::vector<std::int32_t> bins;  ///< bin indices, the seed first
  double weight = 0.0;             ///< total weight of the bins
  Eigen::Vector4d mean = Eigen::Vector4d::Zero();  ///< rotation: unit quaternion (x, y, z, w); position: (x, y, z, 0)
};

/// Greedy clusters of rotation bins (quaternion cells of edge `cell`): the strongest unused bin
/// (ties: smallest cell) seeds a cluster that takes every unused bin in the 3^4 neighbouring
/// cells (and those of the antipodal quaternion) whose mean lies within `radius` radians of
/// the seed's mean. At most `max_clusters` clusters, strongest first.
std::vector<Cluster> rotation_clusters(const HashedBins<4>& bins, double cell, double radius, int max_clusters);

/// Same for position bins (cells of edge `cell` metres, Euclidean radius `radius` metres).
std::vector<Cluster> position_clusters(const HashedBins<3>& bins, double cell, double radius, int max_clusters);

}  // namespace pairgrasp::detail
