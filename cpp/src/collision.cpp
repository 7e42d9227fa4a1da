// GraspChecker: FCL triangle intersections plus sample-based depth and containment.
#include <pairgrasp/collision.hpp>

#include <pairgrasp/error.hpp>

#include "collision_internal.hpp"

#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <queue>
#include <stdexcept>
#include <string>

namespace pairgrasp {

namespace vd = geometry_detail;
using vd::Vec3;

// ---------------------------------------------------------------- helpers

namespace geometry_detail {

std::shared_ptr<FclModel> make_fcl_model(const Points& vertices, const Triangles& faces,
                                         const std::vector<int>& subset) {
  std::vector<int> fs = subset;
  if (fs.empty())
    for (Eigen::Index f = 0; f < faces.rows(); ++f) fs.push_back(static_cast<int>(f));
  if (fs.empty()) return nullptr;
  std::vector<int> remap(vertices.rows(), -1);
  std::vector<fcl::Vector3d> ps;
  std::vector<fcl::Triangle> ts;
  ts.reserve(fs.size());
  for (int f : fs) {
    int id[3];
    for (int k = 0; k < 3; ++k) {
      int& r = remap[faces(f, k)];
      if (r < 0) {
        r = static_cast<int>(ps.size());
        ps.emplace_back(vertices.row(faces(f, k)).transpose());
      }
      id[k] = r;
    }
    ts.emplace_back(id[0], id[1], id[2]);
  }
  auto model = std::make_shared<FclModel>();
  model->beginModel(static_cast<int>(ts.size()), static_cast<int>(ps.size()));
  model->addSubModel(ps, ts);
  model->endModel();
  model->computeLocalAABB();
  return model;
}

Eigen::AlignedBox3d faces_bounds(const Points& vertices, const Triangles& faces,
                                 const std::vector<int>& subset) {
  Eigen::AlignedBox3d box;
  auto add = [&](Eigen::Index f) {
    for (int k = 0; k < 3; ++k) box.extend(Vec3(vertices.row(faces(f, k)).transpose()));
  };
  if (subset.empty())
    for (Eigen::Index f = 0; f < faces.rows(); ++f) add(f);
  else
    for (int f : subset) add(f);
  return box;
}

Eigen::AlignedBox3d transform_box(const Eigen::AlignedBox3d& box, const Pose& pose) {
  Eigen::AlignedBox3d out;
  if (box.isEmpty()) return out;
  for (int c = 0; c < 8; ++c) out.extend(pose * box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c)));
  return out;
}

SurfaceSamples make_samples(const Mesh& mesh, double spacing) {
  SurfaceSamples s;
  std::vector<int> face_of;
  s.points = sample_surface(mesh.vertices, mesh.faces, {}, spacing, &face_of);
  int count = 0;
  const std::vector<int> comp = vertex_components(mesh.vertices, mesh.faces, count);
  s.component.resize(face_of.size());
  for (std::size_t i = 0; i < face_of.size(); ++i) s.component[i] = comp[mesh.faces(face_of[i], 0)];
  s.component_rep.assign(count, Vec3::Zero());
  std::vector<char> seen(count, 0);
  for (Eigen::Index v = 0; v < mesh.vertices.rows(); ++v)
    if (comp[v] >= 0 && !seen[comp[v]]) {
      seen[comp[v]] = 1;
      s.component_rep[comp[v]] = mesh.vertices.row(v).transpose();
    }
  std::vector<Eigen::AlignedBox3d> boxes(s.points.rows());
  for (Eigen::Index i = 0; i < s.points.rows(); ++i) boxes[i].extend(Vec3(s.points.row(i).transpose()));
  s.tree.build(boxes, 8);
  return s;
}

double deepest_inside(const SurfaceSamples& samples, const Pose& to_b, const SurfaceQuery& b,
                      const Eigen::AlignedBox3d& b_bounds, const std::vector<char>& components, double known,
                      double stop) {
  const Bvh& tree = samples.tree;
  if (tree.empty()) return known;
  // Best first: nodes ordered by the deepest any of their samples could be. Signed distance is
  // 1-Lipschitz, so a node whose bounding ball (centre c, radius r) has sd(c) >= r is wholly
  // outside, and none of its samples is deeper than r - sd(c).
  struct Entry {
    double bound;       // deepest any sample of the node could be
    double abs_sd;      // |signed distance| of the node's centre
    Vec3 centre;        // in B's frame
    std::int32_t node;
    bool operator<(const Entry& o) const { return bound < o.bound || (bound == o.bound && node > o.node); }
  };
  std::priority_queue<Entry> queue;
  const double inf = std::numeric_limits<double>::infinity();
  double best = 0.0;
  // `hint`: an upper bound on the centre's unsigned distance (the parent's plus the offset).
  auto push = [&](std::int32_t index, double hint) {
    const BvhNode& node = tree.nodes[index];
    const Vec3 lo(node.lo[0], node.lo[1], node.lo[2]), hi(node.hi[0], node.hi[1], node.hi[2]);
    const double radius = 0.5 * (hi - lo).norm();
    const Vec3 c = to_b * (0.5 * (lo + hi));
    // A ball wholly outside B's bounding box is outside B.
    if (box_dist2(c, b_bounds.min().data(), b_bounds.max().data()) > radius * radius) return;
    const double sd_c = b.signed_distance_hint(c, hint);
    if (sd_c >= radius || radius - sd_c <= best) return;
    queue.push({radius - sd_c, std::abs(sd_c), c, index});
  };
  best = known;
  push(0, inf);
  while (!queue.empty()) {
    const Entry e = queue.top();
    queue.pop();
    if (e.bound <= best) break;  // nothing left can be deeper
    const BvhNode& node = tree.nodes[e.node];
    if (node.count > 0) {
      for (std::int32_t k = node.first; k < node.first + node.count; ++k) {
        const int i = tree.order[k];
        if (!components.empty() && !components[samples.component[i]]) continue;
        const Vec3 p = to_b * Vec3(samples.points.row(i).transpose());
        if (!b_bounds.contains(p)) continue;
        const double sd = b.signed_distance_hint(p, e.abs_sd + (p - e.centre).norm());
        if (sd < 0.0) best = std::max(best, -sd);
        if (best > stop) return best;
      }
    } else {
      for (std::int32_t child : {node.first, node.first + 1}) {
        const BvhNode& cn = tree.nodes[child];
        const Vec3 cc = to_b * (0.5 * (Vec3(cn.lo[0], cn.lo[1], cn.lo[2]) + Vec3(cn.hi[0], cn.hi[1], cn.hi[2])));
        push(child, e.abs_sd + (cc - e.centre).norm());
      }
    }
  }
  return best;
}

}  // namespace geometry_detail

void check_rigid(const Pose& pose, const char* what) {
  const Eigen::Matrix4d& m = pose.matrix();
  if (!m.allFinite()) throw std::invalid_argument(std::string(what) + ": not finite");
  if (m.row(3).transpose() != Eigen::Vector4d(0, 0, 0, 1))
    throw std::invalid_argument(std::string(what) + ": last row must be 0 0 0 1");
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
  const double err = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (err > 1e-6)
    throw std::invalid_argument(std::string(what) + ": rotation is not orthonormal (|R^T R - I| = " +
                                std::to_string(err) + ")");
  if (R.determinant() < 0.0)
    throw std::invalid_argument(std::string(what) + ": rotation is a reflection (determinant -1)");
}

// ---------------------------------------------------------------- Impl

namespace {

void check_option(const char* name, double value, bool positive) {
  if (!std::isfinite(value) || value < 0.0 || (positive && value == 0.0))
    throw std::invalid_argument(std::string(name) + ": expected a finite length " +
                                (positive ? "> 0" : ">= 0") + " (m), got " + std::to_string(value));
}

// Runs a sampling step, naming the option at fault in the error ("sample_spacing: ... would
// make more than N surface samples").
template <class F>
auto renamed(const char* option, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const std::invalid_argument& e) {
    std::string what = e.what();
    if (what.rfind("spacing: ", 0) == 0) what = what.substr(9);
    throw std::invalid_argument(std::string(option) + ": " + what);
  }
}

std::string mm(double metres) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f mm", metres * 1e3);
  return buf;
}

}  // namespace

GraspChecker::Impl::Impl(const Hand& hand_in, const Mesh& target_in, const Mask& free_in,
                         const std::vector<Obstacle>& obstacles_in, const CheckOptions& options_in,
                         const Mesh* geometry)
    : hand(hand_in), target(target_in), obstacles(obstacles_in), options(options_in) {
  check_option("depth_tolerance", options.depth_tolerance, false);
  check_option("contact_gap", options.contact_gap, false);
  check_option("sample_spacing", options.sample_spacing, false);
  check_option("contact_spacing", options.contact_spacing, true);
  check_option("contact_cell", options.contact_cell, true);
  check_option("field_cell", options.field_cell, true);
  if (options.threads < 0) throw std::invalid_argument("threads: expected >= 0, got " + std::to_string(options.threads));
  sample_spacing = options.sample_spacing > 0.0 ? options.sample_spacing : options.depth_tolerance;
  if (!(sample_spacing > 0.0))
    throw std::invalid_argument("sample_spacing: must be > 0 when depth_tolerance is 0");

  const Eigen::Index F = target.faces.rows();
  if (F == 0) throw std::invalid_argument("target: mesh '" + target.source + "' has no faces");
  if (free_in.size() == 0) {
    free = Mask::Constant(F, true);
  } else {
    detail::check_size("free", F, free_in.size());
    free = free_in;
  }
  if (!free.any()) throw std::invalid_argument("no free face left: the free mask of the target marks every face occluded");
  for (std::size_t i = 0; i < obstacles.size(); ++i)
    if (obstacles[i].mesh.faces.rows() == 0)
      throw std::invalid_argument("obstacles[" + std::to_string(i) + "]: mesh '" + obstacles[i].name + "' has no faces");

  // Links.
  const auto& hl = hand.links();
  links.resize(hl.size());
  for (std::size_t l = 0; l < hl.size(); ++l) {
    vd::LinkModel& L = links[l];
    L.name = hl[l].name;
    L.link = &hl[l];
    const Mesh& m = hl[l].mesh;
    L.fcl = vd::make_fcl_model(m.vertices, m.faces);
    L.bounds = vd::faces_bounds(m.vertices, m.faces);
    L.query = std::make_unique<SurfaceQuery>(m);
    L.samples = renamed("sample_spacing", [&] { return vd::make_samples(m, sample_spacing); });
    if (hl[l].active()) {
      L.fcl_active = vd::make_fcl_model(m.vertices, m.faces, hl[l].active_faces);
      L.contact_samples = renamed("contact_spacing", [&] {
        return vd::sample_surface(m.vertices, m.faces, hl[l].active_faces, options.contact_spacing);
      });
    }
  }
  // Scene: target first, then obstacles.
  scene.resize(1 + obstacles.size());
  {
    vd::SceneModel& S = scene[0];
    S.name = "target";
    S.mesh = &target;
    const Mesh& g = geometry ? *geometry : target;
    S.fcl = vd::make_fcl_model(g.vertices, g.faces);
    S.bounds = vd::faces_bounds(target.vertices, target.faces);
    S.query = std::make_unique<SurfaceQuery>(target);
    S.samples = renamed("sample_spacing", [&] { return vd::make_samples(target, sample_spacing); });
  }
  for (std::size_t i = 0; i < obstacles.size(); ++i) {
    vd::SceneModel& S = scene[1 + i];
    S.name = obstacles[i].name.empty() ? "obstacle " + std::to_string(i) : obstacles[i].name;
    S.obstacle = true;
    S.mesh = &obstacles[i].mesh;
    S.fcl = vd::make_fcl_model(S.mesh->vertices, S.mesh->faces);
    S.bounds = vd::faces_bounds(S.mesh->vertices, S.mesh->faces);
    S.query = std::make_unique<SurfaceQuery>(*S.mesh);
  }
  std::vector<int> occ;
  for (Eigen::Index f = 0; f < F; ++f)
    if (!free[f]) occ.push_back(static_cast<int>(f));
  if (!occ.empty()) {
    occluded = vd::make_fcl_model(target.vertices, target.faces, occ);
    occluded_bounds = vd::faces_bounds(target.vertices, target.faces, occ);
  }

  // Links driven by each DOF: those whose pose changes when the DOF moves (mid-range).
  const Eigen::VectorXd lo = hand.dof_lower(), hi = hand.dof_upper();
  const Eigen::VectorXd mid = (lo + hi) / 2;
  const std::vector<Pose> p0 = hand.link_poses(mid);
  dof_links.resize(lo.size());
  for (Eigen::Index k = 0; k < lo.size(); ++k) {
    Eigen::VectorXd q = mid;
    q[k] += 1e-3 * (hi[k] - lo[k]);
    const std::vector<Pose> p1 = hand.link_poses(q, true);
    for (std::size_t l = 0; l < p0.size(); ++l)
      if ((p1[l].matrix() - p0[l].matrix()).cwiseAbs().maxCoeff() > 1e-12) dof_links[k].push_back(static_cast<int>(l));
  }
  if (options.use_distance_field) {
    const auto t0 = std::chrono::steady_clock::now();
    build_fields();
    field_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
}

vd::PairCheck GraspChecker::Impl::check_pair(int l, const Pose& pose, int s, double stop) const {
  const vd::LinkModel& L = links[l];
  const vd::SceneModel& S = scene[s];
  vd::PairCheck r;
  if (!vd::boxes_within(vd::transform_box(L.bounds, pose), S.bounds, options.contact_gap)) return r;
  r.near = true;

  fcl::CollisionRequestd request;  // one contact, yes/no
  fcl::CollisionResultd result;
  fcl::collide(L.fcl.get(), pose, S.fcl.get(), Pose::Identity(), request, result);
  r.intersecting = result.isCollision();

  double depth = 0.0;
  // Target samples inside a closed link (a target corner poking into a flat link); first, as it
  // is usually the deeper side, so that its depth prunes the other search.
  if (!S.obstacle && L.query->closed()) {
    const Pose inv = pose.inverse();
    const vd::SurfaceSamples& T = S.samples;
    std::vector<char> comp_in;
    const bool any = r.intersecting || vd::components_inside(
        T, inv, L.bounds, [&](const Vec3& q) { return L.query->signed_distance(q) < 0.0; }, comp_in);
    if (any) depth = vd::deepest_inside(T, inv, *L.query, L.bounds, comp_in, depth, stop);
  }
  // Link samples inside the scene mesh.
  if (S.query->closed() && depth <= stop) {
    std::vector<char> comp_in;
    const bool any = r.intersecting || vd::components_inside(
        L.samples, pose, S.bounds, [&](const Vec3& p) { return S.query->signed_distance(p) < 0.0; }, comp_in);
    if (any) depth = vd::deepest_inside(L.samples, pose, *S.query, S.bounds, comp_in, depth, stop);
  }
  r.depth = depth;
  r.inside = depth > 0.0;
  return r;
}

bool GraspChecker::Impl::touches_occluded(int l, const Pose& pose) const {
  if (!occluded) return false;
  const vd::LinkModel& L = links[l];
  if (!vd::boxes_within(vd::transform_box(L.bounds, pose), occluded_bounds, options.contact_gap)) return false;
  fcl::CollisionRequestd creq;
  fcl::CollisionResultd cres;
  fcl::collide(L.fcl.get(), pose, occluded.get(), Pose::Identity(), creq, cres);
  if (cres.isCollision()) return true;
  fcl::DistanceRequestd dreq;
  fcl::DistanceResultd dres;
  const double d = fcl::distance(L.fcl.get(), pose, occluded.get(), Pose::Identity(), dreq, dres);
  return d <= options.contact_gap;
}

double GraspChecker::Impl::link_distance(int l, const Pose& pose, bool active) const {
  const vd::LinkModel& L = links[l];
  const vd::FclModel* model = active ? L.fcl_active.get() : L.fcl.get();
  double best = std::numeric_limits<double>::infinity();
  if (!model) return best;
  for (const vd::SceneModel& S : scene) {
    fcl::CollisionRequestd creq;
    fcl::CollisionResultd cres;
    fcl::collide(model, pose, S.fcl.get(), Pose::Identity(), creq, cres);
    if (cres.isCollision()) return 0.0;
    fcl::DistanceRequestd dreq;
    fcl::DistanceResultd dres;
    const double d = fcl::distance(model, pose, S.fcl.get(), Pose::Identity(), dreq, dres);
    best = std::min(best, std::max(d, 0.0));
  }
  return best;
}

GraspChecker::Impl::LinkState GraspChecker::Impl::link_state(int l, const Pose& pose) const {
  LinkState out;
  for (std::size_t s = 0; s < scene.size(); ++s) {
    const bool obstacle = scene[s].obstacle;
    const vd::PairCheck pc = pair(l, pose, static_cast<int>(s), obstacle ? 0.0 : options.depth_tolerance, obstacle);
    if (!pc.intersecting && !pc.inside) continue;
    out.depth = std::max(out.depth, pc.depth);
    out.penetrating = out.penetrating || obstacle || pc.depth > options.depth_tolerance;
  }
  out.pruned = out.penetrating;
  if (!out.pruned) out.pruned = options.use_distance_field ? field_touches_occluded(l, pose) : touches_occluded(l, pose);
  return out;
}

bool GraspChecker::Impl::pruned(const Pose& wrist, const std::vector<Pose>& link_poses) const {
  for (std::size_t l = 0; l < links.size(); ++l)
    if (link_state(static_cast<int>(l), wrist * link_poses[l]).pruned) return true;
  return false;
}

bool GraspChecker::Impl::penetrating(const Pose& wrist, const std::vector<Pose>& link_poses) const {
  for (std::size_t l = 0; l < links.size(); ++l)
    if (link_state(static_cast<int>(l), wrist * link_poses[l]).penetrating) return true;
  return false;
}

LinkStatus GraspChecker::link_status(int link, const Pose& pose) const {
  if (link < 0 || static_cast<std::size_t>(link) >= impl_->links.size())
    throw std::invalid_argument("link: expected an index in [0, " + std::to_string(impl_->links.size()) + "), got " +
                                std::to_string(link));
  return impl_->link_state(link, pose);
}

bool GraspChecker::pruned(const Pose& wrist, const std::vector<Pose>& link_poses) const {
  detail::check_size("link_poses", static_cast<long>(impl_->links.size()), static_cast<long>(link_poses.size()));
  return impl_->pruned(wrist, link_poses);
}

bool GraspChecker::penetrating(const Pose& wrist, const std::vector<Pose>& link_poses) const {
  detail::check_size("link_poses", static_cast<long>(impl_->links.size()), static_cast<long>(link_poses.size()));
  return impl_->penetrating(wrist, link_poses);
}

const std::vector<std::vector<int>>& GraspChecker::dof_links() const { return impl_->dof_links; }

std::vector<Pose> GraspChecker::Impl::target_frame_poses(const Pose& wrist, const Eigen::VectorXd& dofs) const {
  check_rigid(wrist, "wrist");
  std::vector<Pose> poses = hand.link_poses(dofs);
  for (Pose& p : poses) p = wrist * p;
  return poses;
}

CheckResult GraspChecker::Impl::check_poses(const std::vector<Pose>& poses, bool exact_depth,
                                            const std::vector<char>* clear) const {
  // Without exact depths, a link is searched only until it is known to prune the pose: beyond the
  // tolerance in the target, or any depth in an obstacle.
  const double inf = std::numeric_limits<double>::infinity();
  CheckResult r;
  r.links.resize(links.size());
  std::vector<std::string> deep, hit_obstacle, occluding;
  for (std::size_t l = 0; l < links.size(); ++l) {
    LinkCheck& lc = r.links[l];
    lc.link = links[l].name;
    const bool apart = clear && (*clear)[l];
    for (std::size_t s = 0; s < scene.size() && !apart; ++s) {
      const double stop = exact_depth ? inf : (scene[s].obstacle ? 0.0 : options.depth_tolerance);
      const vd::PairCheck pc = pair(static_cast<int>(l), poses[l], static_cast<int>(s), stop);
      if (!pc.intersecting && !pc.inside) continue;
      CollisionPair pair;
      pair.link = lc.link;
      pair.other = scene[s].name;
      pair.obstacle = scene[s].obstacle;
      pair.intersecting = pc.intersecting;
      pair.inside = pc.inside;
      pair.depth = pc.depth;
      r.pairs.push_back(pair);
      lc.colliding = true;
      lc.with.push_back(scene[s].name);
      lc.depth = std::max(lc.depth, pc.depth);
      if (scene[s].obstacle) {
        r.obstacle_collision = true;
        hit_obstacle.push_back(lc.link + " with " + scene[s].name);
      } else {
        r.target_depth = std::max(r.target_depth, pc.depth);
        if (pc.depth > options.depth_tolerance) deep.push_back(lc.link);
      }
    }
    lc.touches_occluded = options.use_distance_field ? field_touches_occluded(static_cast<int>(l), poses[l])
                                                     : touches_occluded(static_cast<int>(l), poses[l]);
    if (lc.touches_occluded) occluding.push_back(lc.link);
    r.collision = r.collision || lc.colliding;
    r.touches_occluded = r.touches_occluded || lc.touches_occluded;
    r.depth = std::max(r.depth, lc.depth);
  }
  r.penetrating = r.target_depth > options.depth_tolerance;
  r.pruned = r.penetrating || r.obstacle_collision || r.touches_occluded;
  auto join = [](const std::vector<std::string>& v) {
    std::string s;
    for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
    return s;
  };
  std::vector<std::string> why;
  if (r.penetrating)
    why.push_back("penetration " + mm(r.target_depth) + " > tolerance " + mm(options.depth_tolerance) +
                  " (" + join(deep) + " into target)");
  if (r.obstacle_collision) why.push_back("obstacle collision (" + join(hit_obstacle) + ")");
  if (r.touches_occluded) why.push_back("touches occluded target faces (" + join(occluding) + ")");
  for (std::size_t i = 0; i < why.size(); ++i) r.reason += (i ? "; " : "") + why[i];
  return r;
}

// ---------------------------------------------------------------- public

GraspChecker::GraspChecker(const Hand& hand, const Mesh& target, const Mask& free,
                           const std::vector<Obstacle>& obstacles, const CheckOptions& options)
    : impl_(std::make_shared<const Impl>(hand, target, free, obstacles, options)) {}

namespace {
// `surface` was split from `given`: its source faces index given's faces and both span one box.
const Mesh& split_from(const FreeSurface& surface, const Mesh& given) {
  const Eigen::Index F = surface.mesh.faces.rows(), G = given.faces.rows();
  if (surface.source_faces.size() != F)
    throw std::invalid_argument("surface: source_faces has " + std::to_string(surface.source_faces.size()) +
                                " entries for " + std::to_string(F) + " faces");
  if (F == 0 || G == 0) throw std::invalid_argument("surface: the target has no faces");
  if (surface.source_faces.minCoeff() < 0 || surface.source_faces.maxCoeff() >= G)
    throw std::invalid_argument("surface: its source faces index a mesh of more than " + std::to_string(G) +
                                " faces, not the mesh given ('" + given.source + "')");
  const Eigen::AlignedBox3d a = vd::faces_bounds(surface.mesh.vertices, surface.mesh.faces);
  const Eigen::AlignedBox3d b = vd::faces_bounds(given.vertices, given.faces);
  const double tol = 1e-9 * std::max(1.0, b.diagonal().norm());
  if (!((a.min() - b.min()).cwiseAbs().maxCoeff() <= tol && (a.max() - b.max()).cwiseAbs().maxCoeff() <= tol))
    throw std::invalid_argument("surface: it spans another box than the mesh given ('" + given.source +
                                "'): not split from it");
  return given;
}
}  // namespace

GraspChecker::GraspChecker(const Hand& hand, const FreeSurface& surface, const Mesh& given,
                           const std::vector<Obstacle>& obstacles, const CheckOptions& options)
    : impl_(std::make_shared<const Impl>(hand, surface.mesh, surface.free, obstacles, options,
                                         &split_from(surface, given))) {}

CheckResult GraspChecker::check(const Pose& wrist, const Eigen::VectorXd& dofs, bool exact_depth) const {
  return impl_->check_poses(impl_->target_frame_poses(wrist, dofs), exact_depth);
}

std::vector<CheckResult> GraspChecker::check_many(const std::vector<Pose>& wrists,
                                                  const std::vector<Eigen::VectorXd>& dofs,
                                                  int threads, bool exact_depth) const {
  if (wrists.size() != dofs.size())
    throw std::invalid_argument("dofs: expected " + std::to_string(wrists.size()) +
                                " DOF vectors (one per wrist pose), got " + std::to_string(dofs.size()));
  for (std::size_t k = 0; k < wrists.size(); ++k)
    check_rigid(wrists[k], ("wrists[" + std::to_string(k) + "]").c_str());
  std::vector<CheckResult> out(wrists.size());
  const int t = threads < 0 ? impl_->options.threads : threads;
  vd::parallel_for(wrists.size(), t, [&](std::size_t k) { out[k] = check(wrists[k], dofs[k], exact_depth); });
  return out;
}

const Hand& GraspChecker::hand() const { return impl_->hand; }
const Mesh& GraspChecker::target() const { return impl_->target; }
const Mask& GraspChecker::free() const { return impl_->free; }
const std::vector<Obstacle>& GraspChecker::obstacles() const { return impl_->obstacles; }
const CheckOptions& GraspChecker::options() const { return impl_->options; }
const SurfaceQuery& GraspChecker::target_query() const { return *impl_->scene[0].query; }
std::vector<int> GraspChecker::link_sample_counts() const {
  std::vector<int> out;
  for (const auto& L : impl_->links) out.push_back(static_cast<int>(L.samples.points.rows()));
  return out;
}
std::size_t GraspChecker::distance_field_bytes() const {
  std::size_t n = 0;
  for (const auto& L : impl_->links)
    n += L.distance.field ? L.distance.field->nbytes() : L.distance.planes.size() * sizeof(Eigen::Vector4d);
  for (const auto& S : impl_->scene) n += S.field ? S.field->nbytes() : 0;
  return n + (impl_->occluded_field ? impl_->occluded_field->nbytes() : 0);
}
double GraspChecker::distance_field_seconds() const { return impl_->field_seconds; }
int GraspChecker::target_sample_count() const { return static_cast<int>(impl_->scene[0].samples.points.rows()); }

}  // namespace pairgrasp
