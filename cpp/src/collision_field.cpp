// GraspChecker on distance fields: the same flags as the exact checks, the exact queries
// deciding wherever a field's bounds do not.
//
// Per link and target: (1) the link's sphere tree against the target's field classifies each
// link component as certainly outside, certainly inside or certainly crossing the target's
// surface (FCL decides the rest); (2) one best-first search over both sample trees (target
// samples inside the link, link samples inside the target) bounds the largest depth, refining
// with the exact signed distance only the samples whose bounds straddle what must be decided
// (inside or not, beyond the tolerance or not, the depth to within the field's error).
#include <pairgrasp/collision.hpp>

#include "collision_internal.hpp"
#include "thread_pool.hpp"

#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pairgrasp {

namespace vd = geometry_detail;
using vd::Interval;
using vd::Vec3;

namespace geometry_detail {

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

SphereTree make_sphere_tree(const Mesh& mesh, const std::vector<int>& faces, double leaf_radius) {
  SphereTree out;
  std::vector<int> fs = faces;
  if (fs.empty())
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) fs.push_back(static_cast<int>(f));
  int count = 0;
  const std::vector<int> comp = vertex_components(mesh.vertices, mesh.faces, count);
  // Pieces per component: split the longest edge until the circumradius about the centroid fits.
  std::vector<std::vector<Tri>> pieces(count);
  for (int f : fs) {
    std::vector<Tri> stack{{Vec3(mesh.vertices.row(mesh.faces(f, 0)).transpose()),
                            Vec3(mesh.vertices.row(mesh.faces(f, 1)).transpose()),
                            Vec3(mesh.vertices.row(mesh.faces(f, 2)).transpose())}};
    std::vector<Tri>& into = pieces[comp[mesh.faces(f, 0)]];
    while (!stack.empty()) {
      const Tri t = stack.back();
      stack.pop_back();
      const Vec3 m = (t[0] + t[1] + t[2]) / 3.0;
      const double r2 = std::max({(t[0] - m).squaredNorm(), (t[1] - m).squaredNorm(), (t[2] - m).squaredNorm()});
      if (r2 <= leaf_radius * leaf_radius) {
        into.push_back(t);
        continue;
      }
      int e = 0;  // longest edge (e, e+1)
      double best = -1.0;
      for (int k = 0; k < 3; ++k) {
        const double len = (t[(k + 1) % 3] - t[k]).squaredNorm();
        if (len > best) best = len, e = k;
      }
      const Vec3 mid = 0.5 * (t[e] + t[(e + 1) % 3]);
      stack.push_back({t[e], mid, t[(e + 2) % 3]});
      stack.push_back({mid, t[(e + 1) % 3], t[(e + 2) % 3]});
    }
  }
  for (const std::vector<Tri>& ps : pieces) {
    if (ps.empty()) continue;
    std::vector<Eigen::AlignedBox3d> boxes(ps.size());
    for (std::size_t i = 0; i < ps.size(); ++i)
      for (const Vec3& v : ps[i]) boxes[i].extend(v);
    Bvh tree;
    tree.build(boxes, 1);
    const std::int32_t base = static_cast<std::int32_t>(out.nodes.size());
    out.roots.push_back(base);
    out.nodes.resize(base + tree.nodes.size());
    // Piece ranges of every node (children after parents in the tree: fill bottom-up).
    std::vector<std::pair<std::int32_t, std::int32_t>> range(tree.nodes.size());
    for (std::size_t n = tree.nodes.size(); n-- > 0;) {
      const BvhNode& b = tree.nodes[n];
      range[n] = b.count > 0 ? std::make_pair(b.first, b.first + b.count)
                             : std::make_pair(range[b.first].first, range[b.first + 1].second);
    }
    for (std::size_t n = 0; n < tree.nodes.size(); ++n) {
      const BvhNode& b = tree.nodes[n];
      SphereTree::Node& node = out.nodes[base + n];
      node.centre = 0.5 * (Vec3(b.lo[0], b.lo[1], b.lo[2]) + Vec3(b.hi[0], b.hi[1], b.hi[2]));
      double r2 = 0.0;
      for (std::int32_t k = range[n].first; k < range[n].second; ++k)
        for (const Vec3& v : ps[tree.order[k]]) r2 = std::max(r2, (v - node.centre).squaredNorm());
      node.radius = std::sqrt(r2) * (1.0 + 1e-12) + 1e-15;
      // The middle piece: a left child's first piece is its parent's, so first pieces would repeat
      // down the left spine; middle ones spread over the surface level by level.
      const Tri& mid = ps[tree.order[range[n].first + (range[n].second - range[n].first) / 2]];
      node.rep = (mid[0] + mid[1] + mid[2]) / 3.0;
      node.left = b.count > 0 ? -1 : base + b.first;
    }
  }
  return out;
}

}  // namespace geometry_detail

std::size_t estimate_field_bytes(const Mesh& target, const Mask& free, const CheckOptions& options) {
  if (!options.use_distance_field) return 0;
  const double cell = options.field_cell;
  DistanceFieldOptions fo;
  fo.cell = cell;
  fo.band = std::max(options.depth_tolerance, options.contact_gap) + 0.25 * cell;
  std::size_t bytes = DistanceField::estimate_bytes(target, fo);
  if (free.size() == static_cast<std::size_t>(target.faces.rows())) {
    Mesh occ;
    occ.vertices = target.vertices;
    std::vector<Eigen::Index> rows;
    for (Eigen::Index f = 0; f < target.faces.rows(); ++f)
      if (!free[static_cast<std::size_t>(f)]) rows.push_back(f);
    occ.faces.resize(static_cast<Eigen::Index>(rows.size()), 3);
    for (std::size_t i = 0; i < rows.size(); ++i) occ.faces.row(static_cast<Eigen::Index>(i)) = target.faces.row(rows[i]);
    fo.band = options.contact_gap + 0.25 * cell;
    bytes += DistanceField::estimate_bytes(occ, fo);
  }
  return bytes;
}

void GraspChecker::Impl::build_fields() {
  const double cell = options.field_cell;
  const double band = std::max(options.depth_tolerance, options.contact_gap) + 0.25 * cell;
  // Every link, the target's field and the occluded faces' field are built at once (each field's
  // own loop runs nested on the same pool).
  const std::size_t L_n = links.size();
  detail::parallel_for(L_n + 2, options.threads, [&](std::size_t task) {
    if (task < L_n) {
      build_link_field(links[task], cell, band);
    } else if (task == L_n) {
      // Signed for a closed target; for an open one unsigned, which bounds clearances only
      // (field_pair() and the contacts then take the exact queries).
      vd::SceneModel& T = scene[0];
      DistanceFieldOptions fo;
      fo.cell = cell;
      fo.band = band;
      fo.threads = options.threads;
      T.field = std::make_unique<DistanceField>(*T.query, fo);
    } else if (occluded) {
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
  });
}

void GraspChecker::Impl::build_link_field(vd::LinkModel& L, double cell, double band) {
  const Mesh& m = L.link->mesh;
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f)
    L.tris.push_back({Vec3(m.vertices.row(m.faces(f, 0)).transpose()), Vec3(m.vertices.row(m.faces(f, 1)).transpose()),
                      Vec3(m.vertices.row(m.faces(f, 2)).transpose())});
  L.surface = vd::make_sphere_tree(m, {}, cell);
  if (L.link->active()) L.active_surface = vd::make_sphere_tree(m, L.link->active_faces, cell);
  if (!L.query->closed()) return;
  // Convex when every vertex lies on the inner side of every face's plane.
  const double eps = 1e-9 * L.bounds.diagonal().norm();
  bool convex = true;
  for (const vd::Tri& t : L.tris) {
    const Vec3 n = (t[1] - t[0]).cross(t[2] - t[0]).normalized();
    const double d = n.dot(t[0]);
    for (Eigen::Index v = 0; v < m.vertices.rows() && convex; ++v)
      convex = n.dot(Vec3(m.vertices.row(v).transpose())) - d <= eps;
    // Coplanar faces give one plane.
    const Eigen::Vector4d pl(n.x(), n.y(), n.z(), d);
    bool seen = false;
    for (const Eigen::Vector4d& q : L.distance.planes) seen = seen || (q - pl).cwiseAbs().maxCoeff() <= 1e-12;
    if (!seen) L.distance.planes.push_back(pl);
  }
  L.distance.slack = 2.0 * L.query->surface_tolerance() + 4.0 * eps + 1e-12;
  if (convex) return;
  L.distance.planes.clear();
  DistanceFieldOptions fo;
  fo.cell = cell;
  fo.band = band;
  fo.threads = options.threads;
  L.distance.field = std::make_unique<DistanceField>(*L.query, fo);
}

namespace {
constexpr double kMargin = 1e-7;  // decisions at 0 are left to the exact path within this (m)
constexpr int kUndecidedVisits = 48;  // nodes visited after an undecided leaf before giving up
constexpr std::size_t kClassifyVisits = 256;
constexpr int kDiveVisits = 96;  // nodes of the depth-first dive for a sample beyond the stop depth  // nodes classified before FCL decides

// Whether p is strictly inside (signed distance < 0, as the exact query says), from the bounds
// when they decide, else from the exact query.
template <class Exact>
bool strictly_inside(const Interval& v, double on_surface, Exact&& exact) {
  if (v.lower > 0.0) return false;
  if (v.upper < -on_surface) return true;
  return exact() < 0.0;
}

Interval field_interval(const DistanceField& f, const Vec3& p) {
  const FieldSample s = f.sample(p);
  return {s.value, s.lower, s.upper, s.in_band};
}

// Scratch buffers of one thread (checks run on several threads; each uses its own).
struct Scratch {
  std::vector<std::int32_t> stack;
  struct Entry {
    double bound;
    std::int32_t index;  // node, or sample when `sample`
    std::int8_t source;
    bool sample;
  };
  std::vector<Entry> heap;
  std::vector<char> comp_link, comp_target;
};
Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

enum Side : int { kOut = 0, kIn = 1, kCross = 2, kUndecided = -1 };

// One component (tree root) of a surface moved by `pose` against a 1-Lipschitz f with bounds
// `f(p)`: kOut when f > m everywhere on it, kIn when f < -m everywhere, kCross when some point
// has f < -m and another f > m (connected: the surface crosses f = 0), else kUndecided.
template <class F>
int classify(const vd::SphereTree& t, std::int32_t root, const Pose& pose, F&& f, double m) {
  // Breadth first: the representative points of the upper levels spread over the surface, so
  // that a crossing shows early.
  std::vector<std::int32_t>& queue = scratch().stack;
  queue.assign(1, root);
  bool in = false, out = false, undecided = false;
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const vd::SphereTree::Node& n = t.nodes[queue[head]];
    if (head >= kClassifyVisits) {
      undecided = true;
      break;
    }
    const Interval c = f(pose * n.centre);
    if (c.lower - n.radius > m) {
      out = true;
    } else if (c.upper + n.radius < -m) {
      in = true;
    } else {
      const Interval r = f(pose * n.rep);
      in = in || r.upper < -m;
      out = out || r.lower > m;
      if (n.left < 0) undecided = true;
      else queue.push_back(n.left), queue.push_back(n.left + 1);
    }
    if (in && out) return kCross;
  }
  if (undecided) return kUndecided;
  return out ? kOut : kIn;
}

// Whether some point of the surface (moved by `pose`) has f <= gap (f: an unsigned distance
// with bounds `f(p)`): 1 certainly, 0 certainly not, -1 undecided.
template <class F>
int touches(const vd::SphereTree& t, const Pose& pose, F&& f, double gap) {
  std::vector<std::int32_t>& stack = scratch().stack;
  stack.assign(t.roots.begin(), t.roots.end());
  bool undecided = false;
  int after = 0;
  while (!stack.empty()) {
    const vd::SphereTree::Node& n = t.nodes[stack.back()];
    stack.pop_back();
    if (undecided && ++after > kUndecidedVisits) break;
    const Interval c = f(pose * n.centre);
    if (c.lower - n.radius > gap) continue;
    if (f(pose * n.rep).upper <= gap) return 1;
    if (n.left < 0) undecided = true;
    else stack.push_back(n.left + 1), stack.push_back(n.left);
  }
  return undecided ? -1 : 0;
}

// A sample set searched for its deepest point inside a solid B (samples mapped into B's frame
// by `to_b`, only those in `b_bounds` and, unless `components` is null, in flagged components).
struct Source {
  const vd::SurfaceSamples* samples = nullptr;
  Pose to_b;
  Eigen::AlignedBox3d b_bounds;
  const std::vector<char>* components = nullptr;
};

// Largest depth M = max(0, max -sd) over the samples of the sources inside B, best first:
// `sd(source, p)` bounds B's signed distance, `refine(source, p, interval)` gives it exactly. The
// search ends once lo > stop, or when M's relation to 0 and to `tol` is certain and M is known to
// within `err` (the interpolation error of tight bounds: est = the largest tight estimate, exact
// value or certain lower bound, whichever is larger). `tol_only`: the search ends once M's relation
// to `tol` is certain.
template <class Sd, class Refine>
vd::DepthBounds deepest(const Source* sources, int count, Sd&& sd, Refine&& refine, double tol, double err,
                        double stop, bool tol_only = false) {
  using Entry = Scratch::Entry;
  std::vector<Entry>& heap = scratch().heap;
  heap.clear();
  auto less = [](const Entry& a, const Entry& b) {
    return a.bound < b.bound || (a.bound == b.bound && (a.source > b.source || (a.source == b.source && a.index > b.index)));
  };
  double lo = 0.0, est = 0.0;
  auto push = [&](const Entry& e) {
    heap.push_back(e);
    std::push_heap(heap.begin(), heap.end(), less);
  };
  auto push_node = [&](int s, std::int32_t index) {
    const Source& S = sources[s];
    const vd::BvhNode& node = S.samples->tree.nodes[index];
    const Vec3 lo3(node.lo[0], node.lo[1], node.lo[2]), hi3(node.hi[0], node.hi[1], node.hi[2]);
    const double radius = 0.5 * (hi3 - lo3).norm();
    const Vec3 c = S.to_b * (0.5 * (lo3 + hi3));
    if (vd::box_dist2(c, S.b_bounds.min().data(), S.b_bounds.max().data()) > radius * radius) return;
    const double bound = radius - sd(s, c).lower;
    if (bound > 0.0 && bound > lo) push({bound, index, static_cast<std::int8_t>(s), false});
  };
  auto point = [&](int s, std::int32_t i) { return Vec3(sources[s].to_b * Vec3(sources[s].samples->points.row(i).transpose())); };
  // Leaf samples: lo, est, and (when `keep`) the samples that may matter, for refinement.
  auto visit_leaf = [&](int s, const vd::BvhNode& node, bool keep) {
    const Source& S = sources[s];
    for (std::int32_t k = node.first; k < node.first + node.count; ++k) {
      const int i = S.samples->tree.order[k];
      if (S.components && !(*S.components)[S.samples->component[i]]) continue;
      const Vec3 p = point(s, i);
      if (!S.b_bounds.contains(p)) continue;
      const Interval v = sd(s, p);
      if (v.lower >= 0.0) continue;
      lo = std::max(lo, -v.upper);
      est = std::max(est, v.tight ? -v.value : -v.upper);
      // Kept while it may matter: refined when it tops the queue.
      if (keep && -v.lower > lo && v.lower != v.upper) push({-v.lower, i, static_cast<std::int8_t>(s), true});
    }
  };
  if (std::isfinite(stop)) {
    // Looking for one sample certainly deeper than `stop`: depth first, the deeper child first,
    // for a bounded number of nodes; the best-first search below takes over when that fails.
    std::vector<std::int32_t>& stack = scratch().stack;
    int visits = 0;
    for (int s = 0; s < count && lo <= stop; ++s) {
      const Source& S = sources[s];
      if (S.samples->tree.empty()) continue;
      auto bound_of = [&](std::int32_t index) {
        const vd::BvhNode& node = S.samples->tree.nodes[index];
        const Vec3 lo3(node.lo[0], node.lo[1], node.lo[2]), hi3(node.hi[0], node.hi[1], node.hi[2]);
        const double radius = 0.5 * (hi3 - lo3).norm();
        const Vec3 c = S.to_b * (0.5 * (lo3 + hi3));
        if (vd::box_dist2(c, S.b_bounds.min().data(), S.b_bounds.max().data()) > radius * radius) return -1.0;
        return radius - sd(s, c).lower;
      };
      stack.assign(1, 0);
      while (!stack.empty() && lo <= stop && visits < kDiveVisits) {
        const vd::BvhNode& node = S.samples->tree.nodes[stack.back()];
        stack.pop_back();
        ++visits;
        if (node.count > 0) {
          visit_leaf(s, node, false);
          continue;
        }
        const double a = bound_of(node.first), b = bound_of(node.first + 1);
        const std::int32_t deeper = a >= b ? node.first : node.first + 1, other = a >= b ? node.first + 1 : node.first;
        if (std::min(a, b) > stop) stack.push_back(other);
        if (std::max(a, b) > stop) stack.push_back(deeper);
      }
    }
    if (lo > stop) return {lo, lo, lo};
  }
  for (int s = 0; s < count; ++s)
    if (!sources[s].samples->tree.empty()) push_node(s, 0);
  double hi = 0.0;
  while (true) {
    hi = heap.empty() ? lo : std::max(lo, heap.front().bound);
    if (lo > stop) break;
    const bool inside_known = lo > 0.0 || hi <= 0.0;
    const bool tol_known = lo > tol || hi <= tol;
    if (tol_known && (tol_only || (inside_known && hi <= est + err))) break;
    std::pop_heap(heap.begin(), heap.end(), less);
    const Entry e = heap.back();
    heap.pop_back();
    const Source& S = sources[e.source];
    if (e.sample) {
      const Vec3 p = point(e.source, e.index);
      const double d = -refine(e.source, p, sd(e.source, p));
      if (d > 0.0) lo = std::max(lo, d), est = std::max(est, d);
      continue;
    }
    const vd::BvhNode& node = S.samples->tree.nodes[e.index];
    if (node.count == 0) {
      push_node(e.source, node.first);
      push_node(e.source, node.first + 1);
      continue;
    }
    visit_leaf(e.source, node, true);
  }
  return {std::clamp(est, lo, hi), lo, hi};
}

}  // namespace

vd::PairCheck GraspChecker::Impl::field_pair(int l, const Pose& pose, int s, double stop, bool intersection) const {
  const vd::LinkModel& L = links[l];
  const vd::SceneModel& S = scene[s];
  if (!S.field || !S.field->is_signed() || L.surface.empty()) return check_pair(l, pose, s, stop);
  vd::PairCheck r;
  if (!vd::boxes_within(vd::transform_box(L.bounds, pose), S.bounds, options.contact_gap)) return r;
  r.near = true;
  const DistanceField& F = *S.field;
  auto target_sd = [&](const Vec3& p) { return field_interval(F, p); };

  // Triangle intersection, per link component: certainly not when every component lies
  // certainly outside or inside the target, certainly when one has points certainly on both
  // sides; else FCL decides.
  Scratch& sc = scratch();
  std::vector<char>& comp_link = sc.comp_link;
  comp_link.assign(L.samples.component_rep.size(), 0);
  const bool comps_match = L.surface.roots.size() == comp_link.size();
  int crossing = 0;
  bool undecided = false, any_in = false;
  for (std::size_t c = 0; c < L.surface.roots.size() && crossing == 0; ++c) {
    const int side = classify(L.surface, L.surface.roots[c], pose, target_sd, kMargin);
    if (side == kCross) crossing = 1;
    else if (side == kUndecided) undecided = true;
    else if (side == kIn && comps_match) comp_link[c] = any_in = true;
  }
  if (crossing == 0 && undecided && !intersection) crossing = -1;  // left open: every sample is searched
  if (crossing == 0 && undecided) {
    fcl::CollisionRequestd request;
    fcl::CollisionResultd result;
    fcl::collide(L.fcl.get(), pose, S.fcl.get(), Pose::Identity(), request, result);
    crossing = result.isCollision() ? 1 : 0;
  }
  if (crossing == 0 && (undecided || !comps_match)) {
    {  // the components' representative vertices say which lie inside
      any_in = vd::components_inside(L.samples, pose, S.bounds, [&](const Vec3& p) {
        return strictly_inside(target_sd(p), S.query->surface_tolerance(), [&] { return S.query->signed_distance(p); });
      }, comp_link);
    }
  }
  r.intersecting = crossing == 1;
  const bool all = crossing != 0;  // crossing or left open: the depth searches take every sample

  // Depth: target samples inside the (closed) link, link samples inside the target.
  const Pose inv = pose.inverse();
  Source sources[2];
  int n = 0;
  if (L.query->closed()) {
    std::vector<char>& comp_target = sc.comp_target;
    const bool any = all || vd::components_inside(S.samples, inv, L.bounds, [&](const Vec3& q) {
      return strictly_inside(L.distance.at(q), L.query->surface_tolerance(), [&] { return L.query->signed_distance(q); });
    }, comp_target);
    if (any) sources[n++] = {&S.samples, inv, L.bounds, all ? nullptr : &comp_target};
  }
  if (all || any_in) sources[n++] = {&L.samples, pose, S.bounds, all ? nullptr : &comp_link};
  if (n == 0) return r;
  const vd::DepthBounds depth = deepest(
      sources, n,
      [&](int src, const Vec3& p) { return sources[src].samples == &L.samples ? target_sd(p) : L.distance.at(p); },
      [&](int src, const Vec3& p, const Interval& v) {
        const double hint = std::isfinite(v.upper) ? std::max(std::abs(v.lower), std::abs(v.upper))
                                                   : std::numeric_limits<double>::infinity();
        return sources[src].samples == &L.samples ? S.query->signed_distance_hint(p, hint)
                                                  : L.query->signed_distance_hint(p, hint);
      },
      options.depth_tolerance, 0.5 * std::sqrt(3.0) * options.field_cell, stop, !intersection);
  r.inside = depth.lo > 0.0;
  // Stopped early: the certain lower bound (beyond the tolerance), as the exact path reports one.
  r.depth = !r.inside ? 0.0 : (depth.lo > stop ? depth.lo : depth.est);
  return r;
}

bool GraspChecker::Impl::field_touches_occluded(int l, const Pose& pose) const {
  if (!occluded_field || links[l].surface.empty()) return touches_occluded(l, pose);
  const vd::LinkModel& L = links[l];
  if (!vd::boxes_within(vd::transform_box(L.bounds, pose), occluded_bounds, options.contact_gap)) return false;
  const DistanceField& F = *occluded_field;
  const int touch = touches(L.surface, pose, [&](const Vec3& p) { return field_interval(F, p); }, options.contact_gap);
  return touch < 0 ? touches_occluded(l, pose) : touch == 1;
}

bool GraspChecker::Impl::active_within(int l, const Pose& pose, double gap) const {
  const vd::SphereTree& tree = links[l].active_surface;
  const vd::SceneModel& T = scene[0];
  if (!options.use_distance_field || !T.field || tree.empty()) return false;
  // Every node's representative is a point of the active faces: its unsigned distance to the
  // target, at most max(upper, -lower) of its field interval, bounds the link's from above (and
  // the obstacles only lower link_distance()'s minimum). A ball certainly beyond the gap holds no
  // such representative (each lies in the balls above it), so its subtree is skipped.
  std::vector<std::int32_t>& stack = scratch().stack;
  stack.assign(tree.roots.begin(), tree.roots.end());
  while (!stack.empty()) {
    const vd::SphereTree::Node& n = tree.nodes[stack.back()];
    stack.pop_back();
    const FieldSample c = T.field->sample(pose * n.centre);
    if (std::max({c.lower, -c.upper, 0.0}) - n.radius > gap) continue;
    const FieldSample f = T.field->sample(pose * n.rep);
    if (std::max(f.upper, -f.lower) <= gap) return true;
    if (n.left >= 0) stack.push_back(n.left + 1), stack.push_back(n.left);
  }
  return false;
}

// How tight link_clearance()'s bound is against the smallest distance at a representative point.
constexpr double kClearanceRatio = 0.75;

double GraspChecker::Impl::link_clearance(int l, const Pose& pose, bool active, double above, bool* exact) const {
  if (exact) *exact = true;
  const vd::LinkModel& L = links[l];
  const vd::SphereTree& tree = active ? L.active_surface : L.surface;
  const vd::SceneModel& T = scene[0];
  if (!options.use_distance_field || !T.field || tree.empty()) return link_distance(l, pose, active);
  const DistanceField& F = *T.field;
  auto exact_value = [&] {
    // Surfaces certainly crossing: FCL finds the intersection, and link_distance() says 0 (the
    // components of the whole surface are connected; the active faces' need not be).
    if (!active)
      for (std::int32_t root : tree.roots)
      if (classify(tree, root, pose, [&](const Vec3& p) { return field_interval(F, p); }, kMargin) == kCross) return 0.0;
    return link_distance(l, pose, active);
  };
  if (!std::isfinite(above)) return exact_value();
  // Lower bound of the target's unsigned distance over the link surface, best first: the ball
  // with the smallest bound is split until that bound is beyond `above` and close to the
  // distance, i.e. within kClearanceRatio of an upper bound of the link's distance (each ball
  // holds a surface point within its radius of the centre), or the ball is small against its
  // bound. Every ball left unsplit bounds at least as high; a leaf within `above` needs the
  // exact value.
  double bound = std::numeric_limits<double>::infinity(), seen = bound;
  std::vector<Scratch::Entry>& heap = scratch().heap;
  heap.clear();
  const auto later = [](const Scratch::Entry& a, const Scratch::Entry& b) { return a.bound > b.bound; };
  auto push = [&](std::int32_t index) {
    const vd::SphereTree::Node& n = tree.nodes[index];
    const FieldSample f = F.sample(pose * n.centre);
    // The ball holds a piece of the surface: some point of it lies within the radius.
    seen = std::min(seen, std::max(f.upper, -f.lower) + n.radius);
    heap.push_back({std::max({f.lower, -f.upper, 0.0}) - n.radius, index, 0, false});
    std::push_heap(heap.begin(), heap.end(), later);
  };
  for (std::int32_t root : tree.roots) push(root);
  bool certain = true;
  while (!heap.empty()) {
    const Scratch::Entry e = heap.front();
    const vd::SphereTree::Node& n = tree.nodes[e.index];
    if (e.bound > above && (e.bound >= kClearanceRatio * seen || n.radius <= 0.25 * e.bound)) {
      bound = std::min(bound, e.bound);
      break;
    }
    std::pop_heap(heap.begin(), heap.end(), later);
    heap.pop_back();
    if (n.left < 0 && e.bound <= above) {
      certain = false;
      break;
    }
    if (n.left < 0) {
      bound = std::min(bound, e.bound);  // a leaf cannot be split: its bound stands
      continue;
    }
    push(n.left);
    push(n.left + 1);
  }
  if (!certain) return exact_value();
  // The obstacles through FCL, as link_distance() measures them.
  const vd::FclModel* model = active ? L.fcl_active.get() : L.fcl.get();
  for (std::size_t s = 1; s < scene.size(); ++s) {
    fcl::CollisionRequestd creq;
    fcl::CollisionResultd cres;
    fcl::collide(model, pose, scene[s].fcl.get(), Pose::Identity(), creq, cres);
    if (cres.isCollision()) return 0.0;
    fcl::DistanceRequestd dreq;
    fcl::DistanceResultd dres;
    const double d = fcl::distance(model, pose, scene[s].fcl.get(), Pose::Identity(), dreq, dres);
    if (std::max(d, 0.0) <= above) return exact_value();
    bound = std::min(bound, std::max(d, 0.0));
  }
  if (exact) *exact = false;
  return bound;
}

}  // namespace pairgrasp
