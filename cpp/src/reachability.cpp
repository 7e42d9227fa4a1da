// Free masks from occluders (distance / inside) and from viewpoints (ray casting).
#include <pairgrasp/reachability.hpp>

#include <pairgrasp/error.hpp>
#include <pairgrasp/surface_query.hpp>

#include "surface_query_internal.hpp"

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

namespace pairgrasp {

namespace vd = geometry_detail;
using vd::Vec3;

namespace {

Mask start_mask(const Mesh& target, const Mask& free) {
  const Eigen::Index F = target.faces.rows();
  if (F == 0) throw std::invalid_argument("target: mesh '" + target.source + "' has no faces");
  if (free.size() == 0) return Mask::Constant(F, true);
  detail::check_size("free", F, free.size());
  return free;
}

void require_some_free(const Mask& m, const std::string& why) {
  if (m.size() == 0 || !m.any()) throw std::invalid_argument("no free face left: " + why);
}

std::vector<std::unique_ptr<SurfaceQuery>> occluder_queries(const std::vector<Mesh>& occluders) {
  std::vector<std::unique_ptr<SurfaceQuery>> out;
  for (std::size_t i = 0; i < occluders.size(); ++i) {
    if (occluders[i].faces.rows() == 0)
      throw std::invalid_argument("occluders[" + std::to_string(i) + "]: mesh '" +
                                  occluders[i].source + "' has no faces");
    out.push_back(std::make_unique<SurfaceQuery>(occluders[i]));
  }
  return out;
}

Vec3 corner(const Mesh& m, Eigen::Index f, int k) { return m.vertices.row(m.faces(f, k)).transpose(); }

}  // namespace

Mask occluded_by(const Mesh& target, const std::vector<Mesh>& occluders, double distance,
                 const Mask& free, int threads) {
  if (!std::isfinite(distance) || distance < 0.0)
    throw std::invalid_argument("distance: expected a finite length >= 0 (m), got " + std::to_string(distance));
  Mask out = start_mask(target, free);
  const auto queries = occluder_queries(occluders);
  const Eigen::Index F = target.faces.rows();
  vd::parallel_for(static_cast<std::size_t>(F), threads, [&](std::size_t fi) {
    const Eigen::Index f = static_cast<Eigen::Index>(fi);
    if (!out[f]) return;
    const Vec3 a = corner(target, f, 0), b = corner(target, f, 1), c = corner(target, f, 2);
    for (const auto& q : queries) {
      // Resolve distances up to `distance` plus a rounding hair (0 stays exact: touching counts).
      const double bound = distance + 4.0 * q->surface_tolerance();
      if (q->triangle_distance(a, b, c, bound) <= bound) {
        out[f] = false;
        return;
      }
      // Not within reach of the occluder's surface: then the whole face is on one side of it.
      if (q->closed() && q->inside((a + b + c) / 3.0)) {
        out[f] = false;
        return;
      }
    }
  });
  require_some_free(out, "every face of '" + target.source + "' is within " + std::to_string(distance) +
                             " m of an occluder, inside one, or was not free to begin with");
  return out;
}

Mask visible_from(const Mesh& target, const Points& viewpoints, const Mask& free,
                  const std::vector<Mesh>& occluders, int threads) {
  if (viewpoints.rows() == 0) throw std::invalid_argument("viewpoints: expected at least one viewpoint");
  for (Eigen::Index i = 0; i < viewpoints.rows(); ++i)
    if (!viewpoints.row(i).allFinite())
      throw std::invalid_argument("viewpoints: row " + std::to_string(i) + " is not finite");
  Mask out = start_mask(target, free);
  const auto queries = occluder_queries(occluders);
  const SurfaceQuery self(target);
  const double eps = std::max(1e3 * self.surface_tolerance(), 1e-12);  // offset off the face
  const Eigen::Index F = target.faces.rows();
  vd::parallel_for(static_cast<std::size_t>(F), threads, [&](std::size_t fi) {
    const Eigen::Index f = static_cast<Eigen::Index>(fi);
    if (!out[f]) return;
    const Vec3 a = corner(target, f, 0), b = corner(target, f, 1), c = corner(target, f, 2);
    const Vec3 n = (b - a).cross(c - a).normalized();
    const Vec3 centre = (a + b + c) / 3.0;
    const Vec3 samples[4] = {centre, centre + 0.8 * (a - centre), centre + 0.8 * (b - centre),
                             centre + 0.8 * (c - centre)};
    bool seen = false;
    for (Eigen::Index v = 0; v < viewpoints.rows() && !seen; ++v) {
      const Vec3 eye = viewpoints.row(v).transpose();
      for (const Vec3& s : samples) {
        const Vec3 to_eye = eye - s;
        const double len = to_eye.norm();
        if (!(n.dot(to_eye) > 1e-12 * len)) continue;  // back-facing or edge-on
        const Vec3 o = s + eps * n;                     // start just off the face, on its front side
        const Vec3 d = eye - o;
        const double t = d.norm();
        if (self.ray_blocked(o, d, t, static_cast<int>(f))) continue;
        bool blocked = false;
        for (const auto& q : queries)
          if (q->ray_blocked(o, d, t)) {
            blocked = true;
            break;
          }
        if (!blocked) {
          seen = true;
          break;
        }
      }
    }
    if (!seen) out[f] = false;
  });
  require_some_free(out, "no face of '" + target.source + "' is seen from the " +
                             std::to_string(viewpoints.rows()) + " viewpoint(s) among the free ones");
  return out;
}

Mask combine_free(const Mask& a, const Mask& b) {
  detail::check_size("b", a.size(), b.size());
  Mask out = (a.array() && b.array()).matrix();
  require_some_free(out, "the masks share no free face");
  return out;
}

}  // namespace pairgrasp
