// Fixed-capacity hashed vote bins and their greedy clustering (see accumulator.hpp).
#include "accumulator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace pairgrasp::detail {

namespace {

std::uint64_t mix(std::uint64_t x) {  // splitmix64 finaliser
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

std::int32_t to_cell(double v, double cell) {
  const double c = std::floor(v / cell);
  constexpr double lim = 1e9;  // far beyond any meaningful grid; keeps the cast defined
  return static_cast<std::int32_t>(std::clamp(c, -lim, lim));
}

template <int D>
bool cell_less(const std::array<std::int32_t, D>& a, const std::array<std::int32_t, D>& b) {
  return std::lexicographical_compare(a.begin(), a.end(), b.begin(), b.end());
}

// Visits the bin indices strongest first, ties broken by the cell (a strict total order, hence
// deterministic), until `visit` returns false. Greedy clustering takes its seeds from the top of
// that order and usually stops long before the end (after `max_clusters` clusters), so the order
// is sorted in stages: the first 2 * max_clusters bins (selected, then sorted), then only if
// needed the rest, which gives the same sequence as one full sort.
template <int D, class Visit>
void strongest_first(const HashedBins<D>& bins, int max_clusters, Visit&& visit) {
  const std::size_t first = 2 * static_cast<std::size_t>(std::max(max_clusters, 1));
  std::vector<std::int32_t> order(bins.bins().size());
  std::iota(order.begin(), order.end(), 0);
  const auto& b = bins.bins();
  auto stronger = [&](std::int32_t x, std::int32_t y) {
    if (b[x].weight != b[y].weight) return b[x].weight > b[y].weight;
    return cell_less<D>(b[x].cell, b[y].cell);
  };
  const auto mid = order.begin() + static_cast<std::ptrdiff_t>(std::min(first, order.size()));
  if (mid != order.end()) std::nth_element(order.begin(), mid, order.end(), stronger);  // the `first` strongest before mid
  std::sort(order.begin(), mid, stronger);
  for (auto it = order.begin(); it != order.end(); ++it) {
    if (it == mid) std::sort(mid, order.end(), stronger);
    if (!visit(*it)) return;
  }
}

// Calls f(neighbour cell) for the 3^D cells around `c` (including c).
template <int D, class F>
void for_neighbours(const std::array<std::int32_t, D>& c, F f) {
  int total = 1;
  for (int k = 0; k < D; ++k) total *= 3;
  for (int code = 0; code < total; ++code) {
    std::array<std::int32_t, D> n = c;
    int r = code;
    for (int k = 0; k < D; ++k) {
      n[k] += r % 3 - 1;
      r /= 3;
    }
    f(n);
  }
}

}  // namespace

template <int D>
HashedBins<D>::HashedBins(std::size_t capacity, std::size_t expected_entries) : capacity_(capacity) {
  const std::size_t held = std::max<std::size_t>(1, std::min(capacity, expected_entries));
  std::size_t size = 16;
  while (size < 4 * held) size <<= 1;
  table_.assign(size, -1);
  mask_ = size - 1;
  bins_.reserve(held);
}

template <int D>
std::size_t HashedBins<D>::slot_of(const Cell& cell) const {
  // One multiply per coordinate (odd constants), then one finalising round: the slot only sets
  // where probing starts, never which bin a cell gets.
  static constexpr std::uint64_t kOdd[4] = {0x9e3779b97f4a7c15ull, 0xc2b2ae3d27d4eb4full, 0x165667b19e3779f9ull,
                                            0xd6e8feb86659fd93ull};
  std::uint64_t h = 0;
  for (int k = 0; k < D; ++k) h += static_cast<std::uint64_t>(static_cast<std::uint32_t>(cell[k])) * kOdd[k];
  return static_cast<std::size_t>(mix(h)) & mask_;
}

namespace {
// Cells compared coordinate by coordinate (std::array's == goes through memcmp).
template <int D>
bool same_cell(const std::array<std::int32_t, D>& a, const std::array<std::int32_t, D>& b) {
  bool same = true;
  for (int k = 0; k < D; ++k) same = same && a[k] == b[k];
  return same;
}
}  // namespace

template <int D>
std::int32_t HashedBins<D>::find(const Cell& cell) const {
  for (std::size_t s = slot_of(cell);; s = (s + 1) & mask_) {
    const std::int32_t b = table_[s];
    if (b < 0) return -1;
    if (same_cell<D>(bins_[b].cell, cell)) return b;
  }
}

template <int D>
std::int32_t HashedBins<D>::add(const Cell& cell, const Value& value, double weight) {
  std::size_t s = slot_of(cell);
  for (;; s = (s + 1) & mask_) {
    const std::int32_t b = table_[s];
    if (b < 0) break;
    if (same_cell<D>(bins_[b].cell, cell)) {
      Bin& bin = bins_[b];
      bin.weight += weight;
      bin.sum += weight * value;
      ++bin.count;
      return b;
    }
  }
  // A new cell. The table holds at most half its size in bins (a quarter as sized), so probing
  // always ends and a miss probes about 1.4 slots.
  if (bins_.size() >= capacity_ || 2 * (bins_.size() + 1) > table_.size()) {
    ++dropped_entries_;
    dropped_weight_ += weight;
    return -1;
  }
  const auto b = static_cast<std::int32_t>(bins_.size());
  Bin bin;
  bin.cell = cell;
  bin.weight = weight;
  bin.sum = weight * value;
  bin.count = 1;
  bins_.push_back(bin);
  table_[s] = b;
  return b;
}

template class HashedBins<3>;
template class HashedBins<4>;

Eigen::Quaterniond canonical_quaternion(Eigen::Quaterniond q) {
  q.normalize();
  const double c[4] = {q.w(), q.x(), q.y(), q.z()};
  for (double v : c) {
    if (v > 0) return q;
    if (v < 0) {
      q.coeffs() = -q.coeffs();
      return q;
    }
  }
  return q;
}

std::array<std::int32_t, 4> quaternion_cell(const Eigen::Quaterniond& q, double cell) {
  return {to_cell(q.x(), cell), to_cell(q.y(), cell), to_cell(q.z(), cell), to_cell(q.w(), cell)};
}

std::array<std::int32_t, 3> position_cell(const Eigen::Vector3d& p, double cell) {
  return {to_cell(p.x(), cell), to_cell(p.y(), cell), to_cell(p.z(), cell)};
}

std::vector<Cluster> rotation_clusters(const HashedBins<4>& bins, double cell, double radius, int max_clusters) {
  const auto& b = bins.bins();
  std::vector<char> used(b.size(), 0);
  std::vector<Cluster> out;
  // angle(q1, q2) <= radius  <=>  |q1 . q2| >= cos(radius / 2)
  const double min_dot = std::cos(0.5 * std::min(radius, 3.14159265358979323846));
  strongest_first(bins, max_clusters, [&](std::int32_t seed) {
    if (static_cast<int>(out.size()) >= max_clusters) return false;
    if (used[seed]) return true;
    const Eigen::Vector4d seed_mean = b[seed].sum.normalized();
    Cluster c;
    Eigen::Vector4d sum = Eigen::Vector4d::Zero();
    auto take = [&](const std::array<std::int32_t, 4>& n) {
      const std::int32_t k = bins.find(n);
      if (k < 0 || used[k]) return;
      const Eigen::Vector4d m = b[k].sum.normalized();
      const double dot = m.dot(seed_mean);
      if (std::abs(dot) < min_dot) return;
      used[k] = 1;
      c.bins.push_back(k);
      c.weight += b[k].weight;
      sum += dot < 0 ? Eigen::Vector4d(-b[k].sum) : b[k].sum;
    };
    take(b[seed].cell);  // the seed first
    for_neighbours<4>(b[seed].cell, take);
    // A rotation near a half turn (w ~ 0) has neighbours written with the opposite sign.
    const Eigen::Quaterniond anti(-seed_mean(3), -seed_mean(0), -seed_mean(1), -seed_mean(2));
    if (anti.w() > -2.0 * cell) for_neighbours<4>(quaternion_cell(anti, cell), take);
    c.mean = sum.normalized();
    out.push_back(std::move(c));
    return true;
  });
  std::stable_sort(out.begin(), out.end(), [](const Cluster& x, const Cluster& y) { return x.weight > y.weight; });
  return out;
}

std::vector<Cluster> position_clusters(const HashedBins<3>& bins, double /*cell*/, double radius, int max_clusters) {
  const auto& b = bins.bins();
  std::vector<char> used(b.size(), 0);
  std::vector<Cluster> out;
  strongest_first(bins, max_clusters, [&](std::int32_t seed) {
    if (static_cast<int>(out.size()) >= max_clusters) return false;
    if (used[seed]) return true;
    const Eigen::Vector3d seed_mean = b[seed].sum / b[seed].weight;
    Cluster c;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    auto take = [&](const std::array<std::int32_t, 3>& n) {
      const std::int32_t k = bins.find(n);
      if (k < 0 || used[k]) return;
      if ((b[k].sum / b[k].weight - seed_mean).norm() > radius) return;
      used[k] = 1;
      c.bins.push_back(k);
      c.weight += b[k].weight;
      sum += b[k].sum;
    };
    take(b[seed].cell);
    for_neighbours<3>(b[seed].cell, take);
    c.mean.head<3>() = sum / c.weight;
    out.push_back(std::move(c));
    return true;
  });
  std::stable_sort(out.begin(), out.end(), [](const Cluster& x, const Cluster& y) { return x.weight > y.weight; });
  return out;
}

}  // namespace pairgrasp::detail
