// GraspChecker on distance fields: the same flags as the exact checks, the exact queries
// deciding wherever a field's bounds do not.
#include <pairgrasp/collision.hpp>

#include "collision_internal.hpp"

#include <fcl/narrowphase/collision.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>

namespace pairgrasp {

namespace vd = validation_detail;
using vd::Interval;
using vd::Vec3;

namespace validation_detail {

Interval LinkDistance::at(const Vec3& q) const {
  if (field) {
    const FieldSample f = field->sample(q);
    return {f.value, f.lower, f.upper, f.in_band};
  }
  double v = -std::numeric_limits<double>::infinity();
  for (const Eigen::Vector4d& pl : planes) v = std::max(v, pl.head<3>().dot(q) - pl[3]);
  // Inside a convex polytope the distance to the boundary is the smallest plane offset; outside
  // the largest offset is only a lower bound.
  if (v <= 0.0) return {v, v - slack, v + slack, true};
  return {v, v - slack, std::numeric_limits<double>::infinity(), false};
}

template <class Sd, class Refine>
DepthBounds deepest_bounds(const SurfaceSamples& samples, const Pose& to_b, const Eigen::AlignedBox3d& b_bounds,
                           const std::vector<char>& components, Sd&& sd, Refine&& refine, double stop) {
  DepthBounds out;
  const Bvh& tree = samples.tree;
  if (tree.empty()) return out;
  // Without a stop the depth is made exact: every sample that may be the deepest (its depth's
  // upper bound reaches the certain lower bound) is kept, nodes are pruned against the lower
  // bound only, and the kept samples are measured exactly at the end.
  const bool exact = !std::isfinite(stop);
  std::vector<std::pair<double, Vec3>> candidates;  // (upper bound of the depth, point)
  // Best first by the deepest any sample of a node could be: sd >= lower(centre) - radius.
  struct Entry {
    double bound;
    std::int32_t node;
    bool operator<(const Entry& o) const { return bound < o.bound || (bound == o.bound && node > o.node); }
  };
  std::priority_queue<Entry> queue;
  auto beaten = [&](double bound) { return bound <= 0.0 || bound <= (exact ? out.lo : out.hi); };
  auto push = [&](std::int32_t index) {
    const BvhNode& node = tree.nodes[index];
    const Vec3 lo(node.lo[0], node.lo[1], node.lo[2]), hi(node.hi[0], node.hi[1], node.hi[2]);
    const double radius = 0.5 * (hi - lo).norm();
    const Vec3 c = to_b * (0.5 * (lo + hi));
    if (box_dist2(c, b_bounds.min().data(), b_bounds.max().data()) > radius * radius) return;
    const double bound = radius - sd(c).lower;
    if (!beaten(bound)) queue.push({bound, index});
  };
  push(0);
  while (!queue.empty()) {
    const Entry e = queue.top();
    queue.pop();
    if (beaten(e.bound)) break;
    const BvhNode& node = tree.nodes[e.node];
    if (node.count == 0) {
      push(node.first);
      push(node.first + 1);
      continue;
    }
    for (std::int32_t k = node.first; k < node.first + node.count; ++k) {
      const int i = tree.order[k];
      if (!components.empty() && !components[samples.component[i]]) continue;
      const Vec3 p = to_b * Vec3(samples.points.row(i).transpose());
      if (!b_bounds.contains(p)) continue;
      const Interval v = sd(p);
      if (v.lower >= 0.0) continue;
      out.est = std::max(out.est, -v.value);
      out.lo = std::max(out.lo, -v.upper);
      out.hi = std::max(out.hi, -v.lower);
      if (exact) candidates.emplace_back(-v.lower, p);
      if (out.lo > stop) return out;
    }
  }
  if (exact) {
    double deepest = 0.0;
    for (const auto& [bound, p] : candidates)
      if (bound >= out.lo && bound > deepest) deepest = std::max(deepest, -refine(p, sd(p)));
    out.est = out.lo = out.hi = deepest;
  }
  return out;
}

}  // namespace validation_detail

void GraspChecker::Impl::build_fields() {
  const double cell = options.field_cell;
  const double band = std::max(options.depth_tolerance, options.contact_gap) + 0.25 * cell;
  for (vd::LinkModel& L : links) {
    const Mesh& m = L.link->mesh;
    for (Eigen::Index f = 0; f < m.faces.rows(); ++f)
      L.tris.push_back({Vec3(m.vertices.row(m.faces(f, 0)).transpose()), Vec3(m.vertices.row(m.faces(f, 1)).transpose()),
                        Vec3(m.vertices.row(m.faces(f, 2)).transpose())});
    if (!L.query->closed()) continue;
    // Convex when every vertex lies on the inner side of every face's plane.
    const double eps = 1e-9 * L.bounds.diagonal().norm();
    bool convex = true;
    for (const vd::Tri& t : L.tris) {
      const Vec3 n = (t[1] - t[0]).cross(t[2] - t[0]).normalized();
      const double d = n.dot(t[0]);
      for (Eigen::Index v = 0; v < m.vertices.rows() && convex; ++v)
        convex = n.dot(Vec3(m.vertices.row(v).transpose())) - d <= eps;
      L.distance.planes.emplace_back(n.x(), n.y(), n.z(), d);
    }
    L.distance.slack = 2.0 * L.query->surface_tolerance() + 4.0 * eps;
    if (convex) continue;
    L.distance.planes.clear();
    DistanceFieldOptions fo;
    fo.cell = cell;
    fo.band = band;
    fo.threads = options.threads;
    L.distance.field = std::make_unique<DistanceField>(*L.query, fo);
  }
  vd::SceneModel& T = scene[0];
  if (T.query->closed()) {
    DistanceFieldOptions fo;
    fo.cell = cell;
    fo.band = band;
    fo.threads = options.threads;
    T.field = std::make_unique<DistanceField>(*T.query, fo);
  }
  if (occluded) {
    Mesh occ = target;
    std::vector<int> rows;
    for (Eigen::Index f = 0; f < target.faces.rows(); ++f)
      if (!free[f]) rows.push_back(static_cast<int>(f));
    occ.faces.resize(static_cast<Eigen::Index>(rows.size()), 3);
    for (std::size_t i = 0; i < rows.size(); ++i) occ.faces.row(static_cast<Eigen::Index>(i)) = target.faces.row(rows[i]);
    occ.closed = false;
    occluded_query = std::make_unique<SurfaceQuery>(occ);
    DistanceFieldOptions fo;
    fo.cell = cell;
    fo.band = options.contact_gap + 0.25 * cell;
    fo.region = occluded_bounds;
    fo.threads = options.threads;
    occluded_field = std::make_unique<DistanceField>(*occluded_query, fo);
  }
}

namespace {

constexpr double kMargin = 1e-7;  // decisions at 0 are left to the exact path within this (m)
constexpr int kSplits = 64;       // triangle splits before an undecided surface test goes exact

// Whether p is strictly inside (signed distance < 0, as the exact query says), from the bounds
// when they decide, else from the exact query.
template <class Exact>
bool strictly_inside(const Interval& v, double on_surface, Exact&& exact) {
  if (v.lower > 0.0) return false;
  if (v.upper < -on_surface) return true;
  return exact() < 0.0;
}

std::vector<vd::Tri> moved(const std::vector<vd::Tri>& tris, const Pose& pose) {
  std::vector<vd::Tri> out(tris.size());
  for (std::size_t i = 0; i < tris.size(); ++i) out[i] = {pose * tris[i][0], pose * tris[i][1], pose * tris[i][2]};
  return out;
}

Interval field_interval(const DistanceField& f, const Vec3& p) {
  const FieldSample s = f.sample(p);
  return {s.value, s.lower, s.upper, s.in_band};
}

}  // namespace

vd::PairCheck GraspChecker::Impl::field_pair(int l, const Pose& pose, int s, double stop) const {
  const vd::LinkModel& L = links[l];
  const vd::SceneModel& S = scene[s];
  if (!S.field) return check_pair(l, pose, s, stop);
  vd::PairCheck r;
  if (!vd::boxes_within(vd::transform_box(L.bounds, pose), S.bounds, options.contact_gap)) return r;
  r.near = true;
  const DistanceField& F = *S.field;
  auto target_sd = [&](const Vec3& p) { return field_interval(F, p); };
  auto target_exact = [&](const Vec3& p, const Interval& v) {
    return S.query->signed_distance_hint(p, std::max(std::abs(v.lower), std::abs(v.upper)));
  };

  // Triangle intersection. Clear when the link's surface lies certainly outside the target (then
  // the surfaces cannot cross); certain when a connected link has points certainly on both sides.
  const std::vector<vd::Tri> tris = moved(L.tris, pose);
  const int reaches_in = vd::surface_below(tris, target_sd, -kMargin, kMargin, F.cell(), kSplits);
  int crossing = -1;
  if (reaches_in == 0) {
    crossing = 0;
  } else if (reaches_in == 1 && L.samples.component_rep.size() == 1) {
    for (const vd::Tri& t : tris)
      for (const Vec3& v : t)
        if (F.sample(v).lower > kMargin) crossing = 1;
  }
  if (crossing < 0) {
    fcl::CollisionRequestd request;
    fcl::CollisionResultd result;
    fcl::collide(L.fcl.get(), pose, S.fcl.get(), Pose::Identity(), request, result);
    crossing = result.isCollision() ? 1 : 0;
  }
  r.intersecting = crossing == 1;

  // Depth bounds, over the samples check_pair() counts.
  vd::DepthBounds depth;
  const Pose inv = pose.inverse();
  if (L.query->closed()) {
    const vd::SurfaceSamples& T = S.samples;
    std::vector<char> comp_in;
    const bool any = r.intersecting || vd::components_inside(T, inv, L.bounds, [&](const Vec3& q) {
      return strictly_inside(L.distance.at(q), L.query->surface_tolerance(), [&] { return L.query->signed_distance(q); });
    }, comp_in);
    if (any)
      depth = vd::deepest_bounds(
          T, inv, L.bounds, comp_in, [&](const Vec3& q) { return L.distance.at(q); },
          [&](const Vec3& q, const Interval& v) {
            return L.query->signed_distance_hint(q, std::max(std::abs(v.lower), std::abs(v.value)) + F.cell());
          },
          stop);
  }
  if (depth.lo <= stop) {
    std::vector<char> comp_in;
    const bool any = r.intersecting || vd::components_inside(L.samples, pose, S.bounds, [&](const Vec3& p) {
      return strictly_inside(target_sd(p), S.query->surface_tolerance(), [&] { return S.query->signed_distance(p); });
    }, comp_in);
    if (any) {
      const vd::DepthBounds d = vd::deepest_bounds(L.samples, pose, S.bounds, comp_in, target_sd, target_exact, stop);
      depth.est = std::max(depth.est, d.est);
      depth.lo = std::max(depth.lo, d.lo);
      depth.hi = std::max(depth.hi, d.hi);
    }
  }
  // Decisions: inside (depth > 0) and, against the target, beyond the tolerance. Where the
  // bounds straddle a threshold the exact search decides.
  const double tol = options.depth_tolerance;
  const bool inside_known = depth.lo > 0.0 || depth.hi <= 0.0;
  const bool deep_known = S.obstacle || depth.lo > tol || depth.hi <= tol;
  if (!inside_known || !deep_known) return check_pair(l, pose, s, stop);
  r.inside = depth.lo > 0.0;
  // Stopped early: the certain lower bound (beyond the tolerance), as the exact path reports one.
  r.depth = !r.inside ? 0.0 : (depth.lo > stop ? depth.lo : std::clamp(depth.est, depth.lo, depth.hi));
  return r;
}

bool GraspChecker::Impl::field_touches_occluded(int l, const Pose& pose) const {
  if (!occluded_field) return touches_occluded(l, pose);
  const vd::LinkModel& L = links[l];
  if (!vd::boxes_within(vd::transform_box(L.bounds, pose), occluded_bounds, options.contact_gap)) return false;
  const DistanceField& F = *occluded_field;
  const int touch = vd::surface_below(
      moved(L.tris, pose), [&](const Vec3& p) { return field_interval(F, p); }, options.contact_gap,
      options.contact_gap, F.cell(), kSplits);
  return touch < 0 ? touches_occluded(l, pose) : touch == 1;
}

}  // namespace pairgrasp
