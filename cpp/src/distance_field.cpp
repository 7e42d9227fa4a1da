// DistanceField: exact distances at the nodes of the bricks near the surface, trilinear between.
#include <pairgrasp/distance_field.hpp>

#include "surface_query_internal.hpp"

#include <algorithm>
#include <limits>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

namespace pairgrasp {

namespace vd = geometry_detail;

namespace {

// Exact distance (signed for a closed mesh) given an upper bound on the unsigned distance.
double exact_distance(const SurfaceQuery& q, const Eigen::Vector3d& p, double bound) {
  if (q.closed()) return q.signed_distance_hint(p, bound);
  const SurfacePoint cp = q.closest(p, bound * (1.0 + 1e-9) + 1e-12);
  return cp.face >= 0 ? cp.distance : q.distance(p);
}

}  // namespace

DistanceField::DistanceField(const SurfaceQuery& query, const DistanceFieldOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!std::isfinite(options.cell) || !(options.cell > 0.0))
    throw std::invalid_argument("cell: expected a finite length > 0 (m), got " + std::to_string(options.cell));
  if (!std::isfinite(options.band) || options.band < 0.0)
    throw std::invalid_argument("band: expected a finite length >= 0 (m), got " + std::to_string(options.band));
  signed_ = query.closed();
  h_ = options.cell;
  band_ = options.band;
  const Mesh& mesh = query.mesh();
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) mesh_box_.extend(Eigen::Vector3d(mesh.vertices.row(mesh.faces(f, k)).transpose()));
  // Rounding: float nodes (relative 2^-24 of values up to the grid's diagonal) and the exact
  // query's on-surface tolerance at the nodes and at the point compared with.
  Eigen::AlignedBox3d region = options.region.isEmpty() ? mesh_box_ : options.region;
  const double brick = kCells * h_;
  region.min().array() -= band_ + brick;
  region.max().array() += band_ + brick;
  origin_ = region.min();
  for (int a = 0; a < 3; ++a) {
    const double n = std::ceil(region.sizes()[a] / brick);
    if (!(n < 2e5)) throw std::invalid_argument("cell: the grid would be too large");
    nb_[a] = std::max(1, static_cast<int>(n));
  }
  const std::int64_t total = static_cast<std::int64_t>(nb_.x()) * nb_.y() * nb_.z();
  if (total * kNodes > (std::int64_t(1) << 31)) throw std::invalid_argument("cell: the grid would be too large");
  const double extent = (Eigen::Vector3d(nb_.cast<double>()) * brick).norm() + mesh_box_.diagonal().norm();
  slack_ = 1.2e-7 * extent + 4.0 * query.surface_tolerance() + 1e-12;

  // Brick centres (exact); a brick is stored when its centre is within band + half-diagonal.
  const double half_diag = 0.5 * std::sqrt(3.0) * brick;
  centre_value_.assign(total, 0.0);
  centre_point_.assign(3 * total, 0.0f);
  vd::parallel_for(static_cast<std::size_t>(total), options.threads, [&](std::size_t i) {
    const int bx = static_cast<int>(i % nb_.x()), by = static_cast<int>((i / nb_.x()) % nb_.y()),
              bz = static_cast<int>(i / (static_cast<std::size_t>(nb_.x()) * nb_.y()));
    const Eigen::Vector3d c = origin_ + brick * Eigen::Vector3d(bx + 0.5, by + 0.5, bz + 0.5);
    SurfacePoint cp;
    if (signed_) {
      centre_value_[i] = query.signed_distance(c, cp);
    } else {
      cp = query.closest(c);
      centre_value_[i] = cp.distance;
    }
    // Relative to the grid's origin: float rounding of at most 2^-24 of the grid's extent.
    for (int a = 0; a < 3; ++a) centre_point_[3 * i + a] = static_cast<float>(cp.point[a] - origin_[a]);
  });
  brick_slot_.assign(total, -1);
  std::vector<std::int64_t> stored;
  for (std::int64_t i = 0; i < total; ++i)
    if (std::abs(centre_value_[i]) <= band_ + half_diag + slack_) {
      brick_slot_[i] = static_cast<std::int32_t>(stored.size());
      stored.push_back(i);
    }

  // Unique nodes of the stored bricks (shared faces computed once), in increasing index order.
  const Eigen::Vector3i nn = node_counts();
  auto node_id = [&](std::int64_t b, int i, int j, int k) {
    const std::int64_t bx = b % nb_.x(), by = (b / nb_.x()) % nb_.y(), bz = b / (std::int64_t(nb_.x()) * nb_.y());
    return ((bz * kCells + k) * nn.y() + by * kCells + j) * nn.x() + bx * kCells + i;
  };
  std::vector<std::int64_t> ids;
  ids.reserve(stored.size() * kNodes);
  for (std::int64_t b : stored)
    for (int k = 0; k < kSide; ++k)
      for (int j = 0; j < kSide; ++j)
        for (int i = 0; i < kSide; ++i) ids.push_back(node_id(b, i, j, k));
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  std::vector<float> values(ids.size());
  vd::parallel_for(ids.size(), options.threads, [&](std::size_t n) {
    const std::int64_t id = ids[n];
    const Eigen::Vector3i ix(static_cast<int>(id % nn.x()), static_cast<int>((id / nn.x()) % nn.y()),
                             static_cast<int>(id / (std::int64_t(nn.x()) * nn.y())));
    const Eigen::Vector3d p = node_position(ix);
    // Hint: the distance at the centre of a brick holding the node, plus the separation.
    const Eigen::Vector3i bi = (ix.array() / kCells).min(nb_.array() - 1);
    const std::int64_t b = brick_index(bi.x(), bi.y(), bi.z());
    const Eigen::Vector3d c = origin_ + brick * (bi.cast<double>() + Eigen::Vector3d::Constant(0.5));
    values[n] = static_cast<float>(exact_distance(query, p, std::abs(centre_value_[b]) + (p - c).norm()));
  });
  brick_nodes_.resize(stored.size() * kNodes);
  std::size_t at = 0;
  for (std::int64_t b : stored)
    for (int k = 0; k < kSide; ++k)
      for (int j = 0; j < kSide; ++j)
        for (int i = 0; i < kSide; ++i) {
          const auto it = std::lower_bound(ids.begin(), ids.end(), node_id(b, i, j, k));
          brick_nodes_[at++] = values[static_cast<std::size_t>(it - ids.begin())];
        }
  build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::size_t DistanceField::estimate_bytes(const Mesh& mesh, const DistanceFieldOptions& options) {
  if (!std::isfinite(options.cell) || !(options.cell > 0.0))
    throw std::invalid_argument("cell: expected a finite length > 0 (m), got " + std::to_string(options.cell));
  if (!std::isfinite(options.band) || options.band < 0.0)
    throw std::invalid_argument("band: expected a finite length >= 0 (m), got " + std::to_string(options.band));
  Eigen::AlignedBox3d box;
  double area = 0.0;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, 0)).transpose(),
                          b = mesh.vertices.row(mesh.faces(f, 1)).transpose(),
                          c = mesh.vertices.row(mesh.faces(f, 2)).transpose();
    box.extend(a), box.extend(b), box.extend(c);
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  if (box.isEmpty()) return 0;
  Eigen::AlignedBox3d region = options.region.isEmpty() ? box : options.region;
  const double brick = kCells * options.cell;
  double total = 1.0;
  for (int a = 0; a < 3; ++a) total *= std::max(1.0, std::ceil((region.sizes()[a] + 2.0 * (options.band + brick)) / brick));
  // A flat shell: the bricks whose centre lies within band + half-diagonal of the surface.
  const double layers = 2.0 * (options.band + 0.5 * std::sqrt(3.0) * brick) / brick;
  const double stored = std::min(total, area / (brick * brick) * layers);
  const double per_brick = sizeof(std::int32_t) + sizeof(double) + 3 * sizeof(float);
  const double per_stored = kNodes * (sizeof(float) + sizeof(std::int64_t) + sizeof(float));
  const double bytes = total * per_brick + stored * per_stored;
  return bytes >= 1e19 ? std::numeric_limits<std::size_t>::max() : static_cast<std::size_t>(bytes);
}

double DistanceField::max_error() const { return 0.5 * std::sqrt(3.0) * h_ + slack_; }

std::size_t DistanceField::nbytes() const {
  return sizeof(*this) + brick_slot_.capacity() * sizeof(std::int32_t) + centre_value_.capacity() * sizeof(double) +
         centre_point_.capacity() * sizeof(float) +
         brick_nodes_.capacity() * sizeof(float);
}

Eigen::Vector3d DistanceField::node_position(const Eigen::Vector3i& index) const {
  return origin_ + h_ * index.cast<double>();
}

std::optional<double> DistanceField::node_value(const Eigen::Vector3i& index) const {
  const Eigen::Vector3i nn = node_counts();
  if ((index.array() < 0).any() || (index.array() >= nn.array()).any()) return std::nullopt;
  // Any stored brick holding the node (a node on a brick face belongs to up to 8 bricks).
  for (int dz = 0; dz < 2; ++dz)
    for (int dy = 0; dy < 2; ++dy)
      for (int dx = 0; dx < 2; ++dx) {
        const Eigen::Vector3i d(dx, dy, dz);
        const Eigen::Vector3i bi = (index - d).array() / kCells;
        const Eigen::Vector3i local = index - bi * kCells;
        if ((index - d).minCoeff() < 0 || (bi.array() >= nb_.array()).any() || (local.array() > kCells).any())
          continue;
        const std::int32_t slot = brick_slot_[brick_index(bi.x(), bi.y(), bi.z())];
        if (slot < 0) continue;
        return brick_nodes_[static_cast<std::size_t>(slot) * kNodes + (local.z() * kSide + local.y()) * kSide + local.x()];
      }
  return std::nullopt;
}

FieldSample DistanceField::sample(const Eigen::Vector3d& p) const {
  FieldSample s;
  const double brick = kCells * h_;
  const Eigen::Vector3d g = (p - origin_) / brick;
  const double inf = std::numeric_limits<double>::infinity();
  if (!(g.x() >= 0.0 && g.y() >= 0.0 && g.z() >= 0.0 && g.x() < nb_.x() && g.y() < nb_.y() && g.z() < nb_.z())) {
    // Beyond the grid, which holds the mesh's box with a margin: outside, at least this far.
    s.value = s.lower = std::sqrt(vd::box_dist2(p, mesh_box_.min().data(), mesh_box_.max().data()));
    s.upper = inf;
    return s;
  }
  const int bx = static_cast<int>(g.x()), by = static_cast<int>(g.y()), bz = static_cast<int>(g.z());
  const std::int64_t b = brick_index(bx, by, bz);
  const std::int32_t slot = brick_slot_[b];
  if (slot < 0) {
    const Eigen::Vector3d c = origin_ + brick * Eigen::Vector3d(bx + 0.5, by + 0.5, bz + 0.5);
    const double r = (p - c).norm() + slack_;
    s.value = centre_value_[b];
    s.lower = s.value - r;
    s.upper = s.value + r;
    // The centre's closest surface point is a surface point: |f(p)| <= |p - point|.
    const float* q = centre_point_.data() + 3 * b;
    const double u = (p - origin_ - Eigen::Vector3d(q[0], q[1], q[2])).norm() + slack_;
    s.lower = std::max(s.lower, signed_ ? -u : 0.0);
    s.upper = std::min(s.upper, u);
    return s;
  }
  double t[3];
  int c[3];
  const double local[3] = {(g.x() - bx) * kCells, (g.y() - by) * kCells, (g.z() - bz) * kCells};
  for (int a = 0; a < 3; ++a) {
    c[a] = std::min(static_cast<int>(local[a]), kCells - 1);
    t[a] = std::clamp(local[a] - c[a], 0.0, 1.0);
  }
  const float* n = brick_nodes_.data() + static_cast<std::size_t>(slot) * kNodes + (c[2] * kSide + c[1]) * kSide + c[0];
  constexpr int sy = kSide, sz = kSide * kSide;
  const double x00 = n[0] + t[0] * (n[1] - n[0]);
  const double x10 = n[sy] + t[0] * (n[sy + 1] - n[sy]);
  const double x01 = n[sz] + t[0] * (n[sz + 1] - n[sz]);
  const double x11 = n[sz + sy] + t[0] * (n[sz + sy + 1] - n[sz + sy]);
  const double y0 = x00 + t[1] * (x10 - x00), y1 = x01 + t[1] * (x11 - x01);
  s.value = y0 + t[2] * (y1 - y0);
  const double err =
      h_ * std::sqrt(t[0] * (1.0 - t[0]) + t[1] * (1.0 - t[1]) + t[2] * (1.0 - t[2])) + slack_;
  s.lower = s.value - err;
  s.upper = s.value + err;
  s.in_band = true;
  return s;
}

}  // namespace pairgrasp
