// Contacts of a grasp: active-surface samples within the contact gap of the target, on free
// faces, thinned to one per grid cell per link.
#include <pairgrasp/grasp.hpp>

#include "collision_internal.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>

namespace pairgrasp {

namespace vd = geometry_detail;
using vd::Vec3;

namespace {

struct Candidate {
  Vec3 point, target_point, normal;
  double distance = 0.0;
  int face = -1;
};

}  // namespace

Contacts find_contacts(const GraspChecker& checker, const Pose& wrist, const Eigen::VectorXd& dofs) {
  const detail::CheckerAccess::Impl& I = detail::CheckerAccess::impl(checker);
  const std::vector<Pose> poses = I.target_frame_poses(wrist, dofs);  // validates both
  const double gap = I.options.contact_gap;
  const double below = std::max(I.options.depth_tolerance, gap);  // deepest accepted contact
  const double reach = std::max(gap, below);
  const double cell = I.options.contact_cell;
  const vd::SceneModel& T = I.scene[0];
  const bool closed = T.query->closed();
  Eigen::AlignedBox3d tb = T.bounds;
  tb.min().array() -= reach;
  tb.max().array() += reach;

  // key: (link, cell x, y, z) -> best candidate; ordered maps make the output deterministic.
  using Key = std::array<std::int64_t, 4>;
  std::map<Key, Candidate> free_cells, occluded_cells;
  for (std::size_t l = 0; l < I.links.size(); ++l) {
    const vd::LinkModel& L = I.links[l];
    if (L.contact_samples.rows() == 0) continue;
    if (!vd::transform_box(L.bounds, poses[l]).intersects(tb)) continue;
    // The target's distance field rejects the samples whose signed distance certainly lies
    // outside [-below, gap] (all of them when a ball of the active surface's tree does); the
    // exact query measures the others.
    const DistanceField* field = closed && I.options.use_distance_field ? T.field.get() : nullptr;
    if (field && !L.active_surface.empty()) {
      bool all_out = true;
      for (std::int32_t root : L.active_surface.roots) {
        const vd::SphereTree::Node& n = L.active_surface.nodes[root];
        const FieldSample f = field->sample(poses[l] * n.centre);
        all_out = all_out && (f.lower - n.radius > gap || f.upper + n.radius < -below);
      }
      if (all_out) continue;
    }
    for (Eigen::Index i = 0; i < L.contact_samples.rows(); ++i) {
      const Vec3 p = poses[l] * Vec3(L.contact_samples.row(i).transpose());
      if (!tb.contains(p)) continue;
      if (field) {
        const FieldSample f = field->sample(p);
        if (f.lower > gap || f.upper < -below) continue;
      }
      SurfacePoint cp = T.query->closest(p, reach * (1.0 + 1e-9) + 1e-15);
      if (cp.face < 0) continue;
      double sd = cp.distance;
      if (closed) sd = T.query->signed_distance(p, cp);
      if (sd > gap || sd < -below) continue;
      Candidate c{p, cp.point, cp.normal, sd, cp.face};
      const Key key = {static_cast<std::int64_t>(l), static_cast<std::int64_t>(std::floor(p.x() / cell)),
                       static_cast<std::int64_t>(std::floor(p.y() / cell)),
                       static_cast<std::int64_t>(std::floor(p.z() / cell))};
      auto& cells = I.free[cp.face] ? free_cells : occluded_cells;
      auto it = cells.find(key);
      if (it == cells.end()) cells.emplace(key, c);
      else if (std::abs(sd) < std::abs(it->second.distance)) it->second = c;
    }
  }

  Contacts out;
  const Eigen::Index n = static_cast<Eigen::Index>(free_cells.size());
  out.points.resize(n, 3);
  out.target_points.resize(n, 3);
  out.normals.resize(n, 3);
  out.distances.resize(n);
  out.faces.resize(n);
  Eigen::Index k = 0;
  for (const auto& [key, c] : free_cells) {
    out.points.row(k) = c.point.transpose();
    out.target_points.row(k) = c.target_point.transpose();
    out.normals.row(k) = c.normal.transpose();
    out.distances[k] = c.distance;
    out.faces[k] = c.face;
    out.links.push_back(static_cast<int>(key[0]));
    out.link_names.push_back(I.links[key[0]].name);
    ++k;
  }
  out.occluded_count = static_cast<int>(occluded_cells.size());
  return out;
}

}  // namespace pairgrasp
