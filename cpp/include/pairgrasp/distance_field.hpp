#pragma once
/// @file distance_field.hpp
/// A narrow-band distance grid of a mesh: exact (signed, for a closed mesh; else unsigned)
/// distances at the nodes of a regular grid, stored only in the bricks that reach within a band
/// of the surface, interpolated trilinearly between them, with a rigorous bound on the error.
///
/// **Error bound.** The signed (and the unsigned) distance f is 1-Lipschitz. Inside a cell of
/// edge h, with the point's fractional coordinates t = (t_x, t_y, t_z) in [0,1]^3, the
/// trilinear value is I = Σ_k w_k f(v_k) with weights w_k >= 0 summing to 1, so
/// |I − f(p)| <= Σ_k w_k |v_k − p| <= sqrt(Σ_k w_k |v_k − p|^2) (Jensen), and the last sum splits
/// per axis into h^2 t_a (1 − t_a): the error is at most h·sqrt(Σ_a t_a (1 − t_a)), which is
/// 0 at the nodes and at most (√3/2)·h at a cell's centre. FieldSample adds to it the nodes'
/// float rounding and the exact query's on-surface tolerance (a few nanometres at most).
///
/// Outside the stored bricks the distance is bounded from the brick's centre (exact there):
/// |f(p) − f(c)| <= |p − c|, and such points are known to lie beyond the band (in magnitude).
/// The centre's closest surface point s_c bounds the magnitude too: |f(p)| <= |p − s_c| (the
/// distance to any surface point), close to |f(p)| where the surface is smooth, so that a depth
/// deep inside is bounded from above within a fraction of a millimetre of its exact value.
/// Beyond the grid the mesh's bounding box gives a lower bound (outside, no upper bound).
///
/// Built once (the nodes in parallel, results independent of the thread count), then queried
/// from any number of threads. Lengths are metres.
#include <pairgrasp/surface_query.hpp>
#include <pairgrasp/types.hpp>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

namespace pairgrasp {

/// Options of DistanceField.
struct DistanceFieldOptions {
  /// Cell edge h (m) of the grid. The interpolation error is at most (√3/2)·h.
  double cell = 0.001;
  /// Half-width (m) of the band stored around the surface: every point whose distance to the
  /// surface is at most `band` lies in a stored brick (interpolated, error <= (√3/2)·h).
  double band = 0.002;
  /// Region to cover (empty: the mesh's bounding box). Points of it beyond the band and
  /// points outside it are still bounded (see FieldSample), only less tightly.
  Eigen::AlignedBox3d region;
  /// Threads of the build: 0 = all cores.
  int threads = 0;
};

/// The field at a point: the exact distance lies in [lower, upper].
struct FieldSample {
  double value = 0.0;  ///< estimate (m): trilinear in the band, the bound's midpoint-free centre value elsewhere
  double lower = -std::numeric_limits<double>::infinity();  ///< exact distance >= lower (m)
  double upper = std::numeric_limits<double>::infinity();   ///< exact distance <= upper (m)
  bool in_band = false;  ///< interpolated from stored nodes (else bounded from a brick centre or the box)
};

/// Narrow-band distance grid of one mesh (see the file comment).
class DistanceField {
 public:
  /// Builds the field of `query`'s mesh: signed when the mesh is closed, else unsigned. Throws
  /// std::invalid_argument for a non-finite or non-positive cell or a negative band, or when the
  /// grid would have more than 2^31 nodes.
  explicit DistanceField(const SurfaceQuery& query, const DistanceFieldOptions& options = {});

  /// An estimate of the peak bytes of building a field of `mesh` with `options`, computed from its
  /// bounding box (or the region) and surface area in microseconds: every brick's table entry and
  /// centre, and the nodes (with the build's temporary node ids) of the bricks a flat surface of
  /// that area passes within the band of. The built field keeps about a third of it (nbytes()).
  /// Used to refuse a field over a memory budget before building it; the same cell and band checks
  /// as the constructor.
  static std::size_t estimate_bytes(const Mesh& mesh, const DistanceFieldOptions& options);

  /// Bounds of the exact distance at p (metres). Thread-safe. p must be finite.
  FieldSample sample(const Eigen::Vector3d& p) const;

  /// Whether the values are signed (closed mesh).
  bool is_signed() const { return signed_; }
  /// Cell edge h (m).
  double cell() const { return h_; }
  /// Half-width of the stored band (m).
  double band() const { return band_; }
  /// Largest error (m) of a value in the band: (√3/2)·h plus rounding.
  double max_error() const;
  /// Bytes held by the grid (nodes, brick table, centres' values and closest points).
  std::size_t nbytes() const;
  /// Seconds spent building.
  double build_seconds() const { return build_seconds_; }
  /// Number of stored bricks (each 4x4x4 cells, 5^3 nodes) and of bricks in the grid.
  int stored_bricks() const { return static_cast<int>(brick_nodes_.size() / kNodes); }
  int total_bricks() const { return static_cast<int>(brick_slot_.size()); }
  /// Number of grid nodes along each axis.
  Eigen::Vector3i node_counts() const { return nb_ * kCells + Eigen::Vector3i::Ones(); }
  /// Position (m) of grid node `index` (0 <= index < node_counts()).
  Eigen::Vector3d node_position(const Eigen::Vector3i& index) const;
  /// The stored value of grid node `index` (metres, as computed by the exact query and rounded
  /// to float), or nothing when its bricks are not stored.
  std::optional<double> node_value(const Eigen::Vector3i& index) const;

 private:
  static constexpr int kCells = 4;                        // cells per brick edge
  static constexpr int kSide = kCells + 1;                // nodes per brick edge
  static constexpr int kNodes = kSide * kSide * kSide;    // nodes per brick

  bool signed_ = true;
  double h_ = 0.0, band_ = 0.0, slack_ = 0.0, build_seconds_ = 0.0;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();  // first node
  Eigen::Vector3i nb_ = Eigen::Vector3i::Zero();      // bricks per axis
  Eigen::AlignedBox3d mesh_box_;
  std::vector<std::int32_t> brick_slot_;  // per brick: index into the stored bricks, -1 when not stored
  std::vector<double> centre_value_;      // per brick: exact distance at its centre
  std::vector<float> centre_point_;       // per brick: the centre's closest surface point - origin_ (x, y, z)
  std::vector<float> brick_nodes_;        // kNodes values per stored brick, x fastest

  std::int64_t brick_index(int bx, int by, int bz) const {
    return (static_cast<std::int64_t>(bz) * nb_.y() + by) * nb_.x() + bx;
  }
};

}  // namespace pairgrasp
