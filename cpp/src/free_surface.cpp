// The free surface at patch resolution: every face classified against the marks (paint, regions,
// occluders, viewpoints, support plane), divided faces bisected at their longest edge's midpoint
// (conforming: a split edge is split in both faces that share it) until no divided patch is longer
// than the resolution.
#include <pairgrasp/free_surface.hpp>

#include <pairgrasp/error.hpp>
#include <pairgrasp/surface_query.hpp>

#include "surface_query_internal.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace pairgrasp {

namespace gd = geometry_detail;
using gd::Vec3;

// ---------------------------------------------------------------- SupportPlane

void SupportPlane::validate() const {
  if (!point.allFinite()) throw std::invalid_argument("support: the plane's point is not finite");
  if (!normal.allFinite()) throw std::invalid_argument("support: the plane's normal is not finite");
  if (!(normal.norm() > 0.0)) throw std::invalid_argument("support: the plane's normal is zero");
}

double SupportPlane::height(const Eigen::Vector3d& p) const { return normal.normalized().dot(p - point); }

SupportPlane SupportPlane::below(const Mesh& target, const Eigen::Vector3d& up) {
  if (!up.allFinite() || !(up.norm() > 0.0)) throw std::invalid_argument("support: the up direction is zero or not finite");
  if (target.vertices.rows() == 0) throw std::invalid_argument("support: the target has no vertices");
  const Eigen::Vector3d n = up.normalized();
  Eigen::Index lowest = 0;
  (target.vertices * n).minCoeff(&lowest);
  SupportPlane s;
  s.point = target.vertices.row(lowest).transpose();
  s.normal = n;
  return s;
}

std::optional<SupportPlane> SupportPlane::under(const Mesh& target, const Mesh& obstacle, double distance) {
  constexpr Eigen::Index kMostFaces = 5000;
  constexpr double kSlack = 1e-6;
  const Eigen::Index F = obstacle.faces.rows();
  if (F == 0 || F > kMostFaces || target.vertices.rows() == 0 || !(distance >= 0.0)) return std::nullopt;
  std::optional<SupportPlane> best;
  double best_area = 0.0;
  for (Eigen::Index f = 0; f < F; ++f) {
    const Eigen::Vector3d a = obstacle.vertices.row(obstacle.faces(f, 0)).transpose();
    const Eigen::Vector3d b = obstacle.vertices.row(obstacle.faces(f, 1)).transpose();
    const Eigen::Vector3d c = obstacle.vertices.row(obstacle.faces(f, 2)).transpose();
    const Eigen::Vector3d cr = (b - a).cross(c - a);
    const double area = 0.5 * cr.norm();
    if (!(area > 0.0) || area <= best_area) continue;
    const Eigen::Vector3d n = cr.normalized();
    const Eigen::VectorXd ht = (target.vertices.rowwise() - a.transpose()) * n;
    const double low = ht.minCoeff();
    if (low < -kSlack || low > distance) continue;
    if (((obstacle.vertices.rowwise() - a.transpose()) * n).maxCoeff() > kSlack) continue;
    // The obstacle's extent in the plane covers the target's (an orthonormal frame u, w of it).
    const Eigen::Vector3d u = (std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY()).cross(n).normalized();
    const Eigen::Vector3d w = n.cross(u);
    const Eigen::VectorXd tu = target.vertices * u, tw = target.vertices * w;
    const Eigen::VectorXd ou = obstacle.vertices * u, ow = obstacle.vertices * w;
    if (ou.minCoeff() > tu.minCoeff() || ou.maxCoeff() < tu.maxCoeff() || ow.minCoeff() > tw.minCoeff() ||
        ow.maxCoeff() < tw.maxCoeff())
      continue;
    best = SupportPlane{a, n};
    best_area = area;
  }
  return best;
}

namespace {

// The state of a patch against one mark, or against all of them.
enum class Mark : std::uint8_t { Free, Occluded, Divided };

std::string fmt_m(double v) {
  std::ostringstream s;
  s.precision(3);
  s << v << " m";
  return s.str();
}

/// The marks, prepared once: queries on the occluders and on the target (self-occlusion of views).
class Marks {
 public:
  /// `reach`: occluders occlude what lies within `distance` of them (else they only block views).
  Marks(const Mesh& target, const Occlusion& o, bool reach) : o_(o), reach_(reach) {
    const Eigen::Index F = target.faces.rows();
    if (o.paint.size() != 0) detail::check_size("paint", F, o.paint.size());
    for (std::size_t i = 0; i < o.regions.size(); ++i) {
      try {
        o.regions[i].validate();
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument("regions[" + std::to_string(i) + "]." + e.what());
      }
    }
    if (!std::isfinite(o.distance) || o.distance < 0.0)
      throw std::invalid_argument("distance: expected a finite length >= 0 (m), got " + std::to_string(o.distance));
    for (std::size_t i = 0; i < o.occluders.size(); ++i) {
      if (o.occluders[i].faces.rows() == 0)
        throw std::invalid_argument("occluders[" + std::to_string(i) + "]: mesh '" + o.occluders[i].source +
                                    "' has no faces");
      occluders_.push_back(std::make_unique<SurfaceQuery>(o.occluders[i]));
    }
    for (Eigen::Index i = 0; i < o.viewpoints.rows(); ++i)
      if (!o.viewpoints.row(i).allFinite())
        throw std::invalid_argument("viewpoints: row " + std::to_string(i) + " is not finite");
    if (o.viewpoints.rows()) self_ = std::make_unique<SurfaceQuery>(target);
    if (o.support) {
      o.support->validate();
      normal_ = o.support->normal.normalized();
      const double lowest = (target.vertices * normal_).minCoeff() - normal_.dot(o.support->point);
      const double diag = (target.bounds.max() - target.bounds.min()).norm();
      if (lowest < -1e-3 * diag)
        throw std::invalid_argument("support: the plane cuts through the target: its lowest point lies " +
                                    fmt_m(-lowest) + " below it (the plane through the lowest point is the default)");
    }
    view_eps_ = self_ ? std::max(1e3 * self_->surface_tolerance(), 1e-12) : 0.0;
  }

  /// The state of triangle (a, b, c) lying in target face `face`, against every mark; `final`
  /// receives the mark a patch that is not divided further takes (free = true).
  Mark classify(const Vec3& a, const Vec3& b, const Vec3& c, int face, bool& final) const {
    // Cheapest first; a patch wholly occluded by one mark needs no other.
    bool any_divided = false;
    bool fin = true;
    for (int k = 0; k < 4; ++k) {
      const Mark m = k == 0 ? paint(a, b, c, face, fin)
                   : k == 1 ? support(a, b, c, fin)
                   : k == 2 ? occluders(a, b, c, fin)
                            : views(a, b, c, face, fin);
      if (m == Mark::Occluded) {
        final = false;
        return Mark::Occluded;
      }
      any_divided = any_divided || m == Mark::Divided;
    }
    final = fin;
    return any_divided ? Mark::Divided : Mark::Free;
  }

 private:
  // Paint (whole faces) then regions (at the corners, edge midpoints and centroid).
  Mark paint(const Vec3& a, const Vec3& b, const Vec3& c, int face, bool& fin) const {
    const bool base = o_.paint.size() == 0 || o_.paint[face];
    if (o_.regions.empty()) {
      if (!base) fin = false;
      return base ? Mark::Free : Mark::Occluded;
    }
    const Vec3 centre = (a + b + c) / 3.0;
    const Vec3 pts[7] = {centre, a, b, c, (a + b) / 2.0, (b + c) / 2.0, (c + a) / 2.0};
    bool seen_free = false, seen_occluded = false, at_centre = base;
    for (int k = 0; k < 7; ++k) {
      bool v = base;
      for (const PaintRegion& r : o_.regions)
        if (r.contains(pts[k])) v = r.free;
      if (k == 0) at_centre = v;
      (v ? seen_free : seen_occluded) = true;
    }
    if (!at_centre) fin = false;
    if (seen_free && seen_occluded) return Mark::Divided;
    return seen_free ? Mark::Free : Mark::Occluded;
  }

  // The support plane: heights are linear over a face, so its corners decide exactly.
  Mark support(const Vec3& a, const Vec3& b, const Vec3& c, bool& fin) const {
    if (!o_.support) return Mark::Free;
    const double p = normal_.dot(o_.support->point);
    const double ha = normal_.dot(a) - p, hb = normal_.dot(b) - p, hc = normal_.dot(c) - p;
    const double lo = std::min({ha, hb, hc}), hi = std::max({ha, hb, hc});
    if (lo > o_.distance) return Mark::Free;
    fin = false;
    return hi <= o_.distance ? Mark::Occluded : Mark::Divided;
  }

  // Occluders: the exact distance to the triangle, then whether one occluder triangle is within
  // reach of all three corners (the distance to a triangle is convex, so of the whole patch).
  Mark occluders(const Vec3& a, const Vec3& b, const Vec3& c, bool& fin) const {
    bool divided = false;
    if (!reach_) return Mark::Free;
    for (const auto& q : occluders_) {
      // Resolve distances up to `distance` plus a rounding hair (0 stays exact: touching counts).
      const double bound = o_.distance + 4.0 * q->surface_tolerance();
      if (q->triangle_distance(a, b, c, bound) > bound) {
        // Not within reach of the occluder's surface: the whole patch is on one side of it.
        if (q->closed() && q->inside((a + b + c) / 3.0)) {
          fin = false;
          return Mark::Occluded;
        }
        continue;
      }
      fin = false;
      if (covered(*q, a, b, c, bound)) return Mark::Occluded;
      divided = true;
    }
    return divided ? Mark::Divided : Mark::Free;
  }

  static bool covered(const SurfaceQuery& q, const Vec3& a, const Vec3& b, const Vec3& c, double bound) {
    const Mesh& m = q.mesh();
    const Vec3 probes[4] = {(a + b + c) / 3.0, a, b, c};
    for (const Vec3& p : probes) {
      const SurfacePoint near = q.closest(p);
      if (near.face < 0) continue;
      const Vec3 t0 = m.vertices.row(m.faces(near.face, 0)).transpose();
      const Vec3 t1 = m.vertices.row(m.faces(near.face, 1)).transpose();
      const Vec3 t2 = m.vertices.row(m.faces(near.face, 2)).transpose();
      bool all = true;
      for (const Vec3* v : {&a, &b, &c})
        if ((gd::closest_on_triangle(*v, t0, t1, t2) - *v).norm() > bound) {
          all = false;
          break;
        }
      if (all) return true;
    }
    return false;
  }

  // Viewpoints: the patch's sample points, each seen from some viewpoint or not.
  Mark views(const Vec3& a, const Vec3& b, const Vec3& c, int face, bool& fin) const {
    if (o_.viewpoints.rows() == 0) return Mark::Free;
    const Vec3 n = (b - a).cross(c - a).normalized();
    const Vec3 centre = (a + b + c) / 3.0;
    const Vec3 samples[4] = {centre, centre + 0.8 * (a - centre), centre + 0.8 * (b - centre),
                             centre + 0.8 * (c - centre)};
    int seen = 0;
    for (const Vec3& s : samples) {
      for (Eigen::Index v = 0; v < o_.viewpoints.rows(); ++v)
        if (sees(o_.viewpoints.row(v).transpose(), s, n, face)) {
          ++seen;
          break;
        }
    }
    if (seen == 0) {
      fin = false;
      return Mark::Occluded;
    }
    return seen == 4 ? Mark::Free : Mark::Divided;
  }

  bool sees(const Vec3& eye, const Vec3& s, const Vec3& n, int face) const {
    const Vec3 to_eye = eye - s;
    if (!(n.dot(to_eye) > 1e-12 * to_eye.norm())) return false;  // back-facing or edge-on
    const Vec3 o = s + view_eps_ * n;                              // just off the face, on its front
    const Vec3 d = eye - o;
    const double t = d.norm();
    if (self_->ray_blocked(o, d, t, face)) return false;
    for (const auto& q : occluders_)
      if (q->ray_blocked(o, d, t)) return false;
    return true;
  }

  const Occlusion& o_;
  bool reach_ = true;
  std::vector<std::unique_ptr<SurfaceQuery>> occluders_;
  std::unique_ptr<SurfaceQuery> self_;
  Eigen::Vector3d normal_ = Eigen::Vector3d::UnitZ();
  double view_eps_ = 0.0;
};

// A patch: corners (indices into the growing vertex list), its target face, and its state.
struct Patch {
  std::array<int, 3> v;
  int face;
  Mark mark;   // Free / Occluded: settled; Divided: to split
  bool free;   // the final mark once settled
};

std::uint64_t edge_key(int a, int b) {
  const auto lo = static_cast<std::uint32_t>(std::min(a, b)), hi = static_cast<std::uint32_t>(std::max(a, b));
  return (std::uint64_t(lo) << 32) | hi;
}

std::string covered_by(const Occlusion& o) {
  std::vector<std::string> what;
  if (o.paint.size() || !o.regions.empty()) what.push_back("the paint");
  if (!o.occluders.empty()) what.push_back(std::to_string(o.occluders.size()) + " occluder(s) within " + fmt_m(o.distance));
  if (o.support) what.push_back("the support within " + fmt_m(o.distance));
  if (o.viewpoints.rows()) what.push_back("what " + std::to_string(o.viewpoints.rows()) + " viewpoint(s) do not see");
  std::string s;
  for (std::size_t i = 0; i < what.size(); ++i) s += (i ? (i + 1 == what.size() ? " and " : ", ") : "") + what[i];
  return s.empty() ? "nothing" : s;
}

FreeSurface refine(const Mesh& target, const Occlusion& occlusion, double resolution, int threads, bool reach) {
  if (std::isnan(resolution) || !(resolution > 0.0))
    throw std::invalid_argument("resolution: expected a length > 0 (m; infinity: whole faces), got " +
                                std::to_string(resolution));
  const Eigen::Index F = target.faces.rows();
  if (F == 0) throw std::invalid_argument("target: mesh '" + target.source + "' has no faces");
  const Marks marks(target, occlusion, reach);

  std::vector<Vec3> verts(static_cast<std::size_t>(target.vertices.rows()));
  for (Eigen::Index i = 0; i < target.vertices.rows(); ++i) verts[std::size_t(i)] = target.vertices.row(i).transpose();
  std::vector<Patch> patches(static_cast<std::size_t>(F));
  for (Eigen::Index f = 0; f < F; ++f)
    patches[std::size_t(f)] = Patch{{target.faces(f, 0), target.faces(f, 1), target.faces(f, 2)}, int(f), Mark::Divided, true};
  std::vector<char> todo(patches.size(), 1);  // patches to classify
  std::vector<char> split_face(static_cast<std::size_t>(F), 0);

  for (int round = 0;; ++round) {
    // Classify the new patches; a divided one no longer than the resolution settles on its final mark.
    gd::parallel_for(patches.size(), threads, [&](std::size_t i) {
      if (!todo[i]) return;
      Patch& p = patches[i];
      const Vec3 &a = verts[std::size_t(p.v[0])], &b = verts[std::size_t(p.v[1])], &c = verts[std::size_t(p.v[2])];
      bool fin = true;
      p.mark = marks.classify(a, b, c, p.face, fin);
      p.free = fin;
      if (p.mark == Mark::Divided) {
        const double longest = std::max({(a - b).norm(), (b - c).norm(), (c - a).norm()});
        if (longest <= resolution) p.mark = fin ? Mark::Free : Mark::Occluded;
      }
    });
    // The edges to split: the longest edge of every divided patch (longest-edge bisection: a long
    // thin face that a mark crosses is cut across its length, not into ever thinner slivers along
    // it, so the pieces grow with the length of the mark's boundary, not with the face's area),
    // midpoints numbered in patch order.
    std::unordered_map<std::uint64_t, int> mid;
    for (const Patch& p : patches) {
      if (p.mark != Mark::Divided) continue;
      split_face[std::size_t(p.face)] = 1;
      int longest = 0;
      double length = -1.0;
      for (int k = 0; k < 3; ++k) {
        const double l = (verts[std::size_t(p.v[k])] - verts[std::size_t(p.v[(k + 1) % 3])]).squaredNorm();
        if (l > length) length = l, longest = k;
      }
      const int a = p.v[longest], b = p.v[(longest + 1) % 3];
      if (mid.emplace(edge_key(a, b), int(verts.size())).second)
        verts.push_back((verts[std::size_t(a)] + verts[std::size_t(b)]) / 2.0);
    }
    if (mid.empty()) break;
    if (round >= 400) throw std::logic_error("free_surface: refinement did not converge");
    // Split every patch by the midpoints on its edges (one, two or three: its own longest edge and
    // its neighbours'); a settled one keeps its mark (a part of a settled patch is settled the same
    // way), a divided one's pieces are classified again.
    std::vector<Patch> next;
    std::vector<char> next_todo;
    next.reserve(patches.size() * 2);
    for (std::size_t i = 0; i < patches.size(); ++i) {
      const Patch& p = patches[i];
      int m[3];
      int count = 0;
      for (int k = 0; k < 3; ++k) {
        const auto it = mid.find(edge_key(p.v[k], p.v[(k + 1) % 3]));
        m[k] = it == mid.end() ? -1 : it->second;
        count += m[k] >= 0;
      }
      const bool divided = p.mark == Mark::Divided;
      auto emit = [&](int x, int y, int z) {
        next.push_back(Patch{{x, y, z}, p.face, p.mark, p.free});
        next_todo.push_back(divided ? 1 : 0);
      };
      if (count == 0) {
        emit(p.v[0], p.v[1], p.v[2]);
        continue;
      }
      split_face[std::size_t(p.face)] = 1;
      if (count == 3) {
        emit(p.v[0], m[0], m[2]);
        emit(m[0], p.v[1], m[1]);
        emit(m[2], m[1], p.v[2]);
        emit(m[0], m[1], m[2]);
        continue;
      }
      // Rotate so that edge 0 (v0 -> v1) is split; with two split edges, edge 1 is the other.
      int r = 0;
      if (count == 1) {
        while (m[r] < 0) ++r;
      } else {
        while (!(m[r] >= 0 && m[(r + 1) % 3] >= 0)) ++r;
      }
      const int a = p.v[r], b = p.v[(r + 1) % 3], c = p.v[(r + 2) % 3];
      const int mab = m[r], mbc = m[(r + 1) % 3];
      if (count == 1) {
        emit(a, mab, c);
        emit(mab, b, c);
      } else {
        emit(mab, b, mbc);
        // The quad a, mab, mbc, c by its shorter diagonal.
        if ((verts[std::size_t(a)] - verts[std::size_t(mbc)]).squaredNorm() <=
            (verts[std::size_t(mab)] - verts[std::size_t(c)]).squaredNorm()) {
          emit(a, mab, mbc);
          emit(a, mbc, c);
        } else {
          emit(a, mab, c);
          emit(mab, mbc, c);
        }
      }
    }
    patches = std::move(next);
    todo = std::move(next_todo);
  }

  FreeSurface out;
  out.resolution = resolution;
  out.split_faces = static_cast<int>(std::count(split_face.begin(), split_face.end(), 1));
  const Eigen::Index P = static_cast<Eigen::Index>(patches.size());
  out.free.resize(P);
  out.source_faces.resize(P);
  for (Eigen::Index i = 0; i < P; ++i) {
    out.free[i] = patches[std::size_t(i)].free;
    out.source_faces[i] = patches[std::size_t(i)].face;
  }
  if (out.split_faces == 0) {
    out.mesh = target;
  } else {
    Points V(static_cast<Eigen::Index>(verts.size()), 3);
    for (std::size_t i = 0; i < verts.size(); ++i) V.row(Eigen::Index(i)) = verts[i].transpose();
    Triangles T(P, 3);
    for (Eigen::Index i = 0; i < P; ++i)
      for (int k = 0; k < 3; ++k) T(i, k) = patches[std::size_t(i)].v[std::size_t(k)];
    // The pieces keep the target's winding and vertices; no welding, no re-orientation, so that
    // face k of the result is patch k.
    MeshLoadOptions keep;
    keep.weld_tolerance = 0.0;
    keep.orient = false;
    out.mesh = make_mesh(V, T, target.source, keep);
    if (out.mesh.faces.rows() != P)
      throw std::logic_error("free_surface: a split face of '" + target.source + "' came out degenerate");
  }
  if (!out.free.any())
    throw std::invalid_argument("no free face left: every part of '" + target.source + "' is covered by " +
                                covered_by(occlusion));
  return out;
}

}  // namespace

FreeSurface free_surface(const Mesh& target, const Occlusion& occlusion, double resolution, int threads) {
  return refine(target, occlusion, resolution, threads, true);
}

// ---------------------------------------------------------------- per-face masks

Mask occluded_by(const Mesh& target, const std::vector<Mesh>& occluders, double distance, const Mask& free,
                 int threads) {
  if (free.size() != 0) detail::check_size("free", target.faces.rows(), free.size());
  Occlusion o;
  o.paint = free;
  o.occluders = occluders;
  o.distance = distance;
  return free_surface(target, o, std::numeric_limits<double>::infinity(), threads).free;
}

Mask visible_from(const Mesh& target, const Points& viewpoints, const Mask& free, const std::vector<Mesh>& occluders,
                  int threads) {
  if (viewpoints.rows() == 0) throw std::invalid_argument("viewpoints: expected at least one viewpoint");
  if (free.size() != 0) detail::check_size("free", target.faces.rows(), free.size());
  Occlusion o;
  o.paint = free;
  o.viewpoints = viewpoints;
  o.occluders = occluders;  // here they only block views
  return refine(target, o, std::numeric_limits<double>::infinity(), threads, false).free;
}

Mask combine_free(const Mask& a, const Mask& b) {
  detail::check_size("b", a.size(), b.size());
  Mask out = (a.array() && b.array()).matrix();
  if (out.size() == 0 || !out.any()) throw std::invalid_argument("no free face left: the masks share no free face");
  return out;
}

// ---------------------------------------------------------------- the support as an obstacle

Mesh support_box(const SupportPlane& support, const Mesh& target, double margin) {
  support.validate();
  if (!std::isfinite(margin) || !(margin > 0.0))
    throw std::invalid_argument("margin: expected a length > 0 (m), got " + std::to_string(margin));
  if (target.vertices.rows() == 0) throw std::invalid_argument("support: the target has no vertices");
  const Vec3 n = support.normal.normalized();
  // An orthonormal frame (u, w, n) of the plane.
  const Vec3 u = (std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(n).normalized();
  const Vec3 w = n.cross(u);
  const Eigen::VectorXd pu = target.vertices * u, pw = target.vertices * w;
  const double u0 = pu.minCoeff() - margin, u1 = pu.maxCoeff() + margin;
  const double w0 = pw.minCoeff() - margin, w1 = pw.maxCoeff() + margin;
  const double top = n.dot(support.point);
  Points V(8, 3);
  int k = 0;
  for (double h : {top - margin, top})
    for (double a : {u0, u1})
      for (double b : {w0, w1}) V.row(k++) = (a * u + b * w + h * n).transpose();
  // Corners: k = 4*level + 2*i(u) + j(w); faces wound outward (u, w, n right-handed).
  Triangles T(12, 3);
  T << 0, 2, 3, 0, 3, 1,   // bottom (-n)
      4, 5, 7, 4, 7, 6,    // top (+n)
      0, 1, 5, 0, 5, 4,    // -u
      2, 6, 7, 2, 7, 3,    // +u
      0, 4, 6, 0, 6, 2,    // -w
      1, 3, 7, 1, 7, 5;    // +w
  return make_mesh(V, T, "support");
}

}  // namespace pairgrasp
