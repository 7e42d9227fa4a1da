#pragma once
// Internal helpers of the surface area (unit facets, pair index): a hashed uniform grid over 3-D
// points; parallel loops come from the shared pool (thread_pool.hpp).
#include <Eigen/Core>

#include "thread_pool.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

namespace pairgrasp::detail {

/// Worker threads for `requested` (0: all cores), never more than `work_items` (at least 1).
inline int resolve_threads(int requested, std::size_t work_items) {
  const int n = resolve_threads(requested);
  return static_cast<int>(std::max<std::size_t>(1, std::min<std::size_t>(static_cast<std::size_t>(n), work_items)));
}

/// Integer cell coordinates of a uniform grid, packed into 63 bits (21 per axis).
class GridFrame {
 public:
  GridFrame() = default;
  /// A grid of cubic cells of side `cell` (> 0) whose origin is `lo`. The cell is enlarged if the
  /// box [lo, hi] would need more than 2^21 - 8 cells along an axis.
  GridFrame(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double cell) : lo_(lo) {
    const double ext = (hi - lo).maxCoeff();
    const double max_cells = double((1 << 21) - 8);
    if (!(cell > 0.0) || !std::isfinite(cell)) cell = ext > 0 ? ext : 1.0;
    if (ext / cell > max_cells) cell = ext / max_cells;
    cell_ = cell;
    inv_ = 1.0 / cell;
  }
  double cell() const { return cell_; }
  /// Cell coordinates of a point (clamped into the grid).
  Eigen::Array3i coords(const double* p) const {
    Eigen::Array3i c;
    for (int k = 0; k < 3; ++k) {
      double v = std::floor((p[k] - lo_[k]) * inv_);
      v = std::min(std::max(v, 0.0), double((1 << 21) - 1));
      c[k] = static_cast<int>(v);
    }
    return c;
  }
  static std::uint64_t key(int x, int y, int z) {
    return (std::uint64_t(x) << 42) | (std::uint64_t(y) << 21) | std::uint64_t(z);
  }
  static bool valid(int x, int y, int z) {
    return x >= 0 && y >= 0 && z >= 0 && x < (1 << 21) && y < (1 << 21) && z < (1 << 21);
  }
  std::uint64_t key(const double* p) const {
    const auto c = coords(p);
    return key(c[0], c[1], c[2]);
  }

 private:
  Eigen::Vector3d lo_ = Eigen::Vector3d::Zero();
  double cell_ = 1.0, inv_ = 1.0;
};

/// A static hashed grid: items sorted by cell, each occupied cell mapped to its run of items.
class StaticGrid {
 public:
  StaticGrid() = default;
  /// `pos(i)` gives a pointer to the 3 coordinates of item i, for i in [0, n).
  template <class Pos>
  void build(const GridFrame& frame, std::size_t n, Pos pos) {
    frame_ = frame;
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(n);
    for (std::size_t i = 0; i < n; ++i) keyed[i] = {frame_.key(pos(i)), std::uint32_t(i)};
    std::sort(keyed.begin(), keyed.end());
    items_.resize(n);
    cells_.clear();
    cells_.reserve(n / 2 + 1);
    for (std::size_t b = 0; b < n;) {
      std::size_t e = b;
      while (e < n && keyed[e].first == keyed[b].first) {
        items_[e] = keyed[e].second;
        ++e;
      }
      cells_.emplace(keyed[b].first, std::make_pair(std::uint32_t(b), std::uint32_t(e)));
      b = e;
    }
  }
  const GridFrame& frame() const { return frame_; }
  /// Items of cell (x, y, z) as [begin, end) into items().
  std::pair<std::uint32_t, std::uint32_t> cell(int x, int y, int z) const {
    if (!GridFrame::valid(x, y, z)) return {0, 0};
    auto it = cells_.find(GridFrame::key(x, y, z));
    return it == cells_.end() ? std::make_pair(0u, 0u) : it->second;
  }
  const std::vector<std::uint32_t>& items() const { return items_; }
  /// Occupied cells, each as (key, [begin, end)) in key order.
  std::vector<std::pair<std::uint64_t, std::pair<std::uint32_t, std::uint32_t>>> sorted_cells() const {
    std::vector<std::pair<std::uint64_t, std::pair<std::uint32_t, std::uint32_t>>> out(cells_.begin(),
                                                                                        cells_.end());
    std::sort(out.begin(), out.end());
    return out;
  }
  static Eigen::Array3i decode(std::uint64_t key) {
    const std::uint64_t m = (1u << 21) - 1;
    return Eigen::Array3i(int((key >> 42) & m), int((key >> 21) & m), int(key & m));
  }

 private:
  GridFrame frame_;
  std::vector<std::uint32_t> items_;
  std::unordered_map<std::uint64_t, std::pair<std::uint32_t, std::uint32_t>> cells_;
};

/// Calls f(x, y, z) for every cell at Chebyshev distance exactly `ring` from c.
template <class F>
void for_each_ring_cell(const Eigen::Array3i& c, int ring, F f) {
  if (ring == 0) {
    f(c[0], c[1], c[2]);
    return;
  }
  for (int dx = -ring; dx <= ring; ++dx)
    for (int dy = -ring; dy <= ring; ++dy) {
      const bool edge_xy = std::abs(dx) == ring || std::abs(dy) == ring;
      if (edge_xy) {
        for (int dz = -ring; dz <= ring; ++dz) f(c[0] + dx, c[1] + dy, c[2] + dz);
      } else {
        f(c[0] + dx, c[1] + dy, c[2] - ring);
        f(c[0] + dx, c[1] + dy, c[2] + ring);
      }
    }
}

}  // namespace pairgrasp::detail
