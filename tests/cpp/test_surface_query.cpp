// SurfaceQuery against independent facts: brute-force scans over all triangles (with a point-
// triangle distance written here), analytic box / convex-polyhedron inside tests and distances,
// analytic ray-box and ray-polyhedron intersections.
#include <pairgrasp/surface_query.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

#include "test_meshes.hpp"

using namespace pairgrasp;
using Eigen::Vector3d;
namespace tmesh = pairgrasp::testing_meshes;

namespace {

// Independent point-triangle distance: the plane projection if it falls inside the triangle
// (same-side tests), else the nearest of the three edges (clamped projections).
double seg_dist(const Vector3d& p, const Vector3d& a, const Vector3d& b) {
  const Vector3d ab = b - a;
  double t = (p - a).dot(ab) / ab.squaredNorm();
  t = std::max(0.0, std::min(1.0, t));
  return (a + t * ab - p).norm();
}
double tri_dist(const Vector3d& p, const Vector3d& a, const Vector3d& b, const Vector3d& c) {
  const Vector3d n = (b - a).cross(c - a).normalized();
  const Vector3d q = p - n * (p - a).dot(n);
  const bool in = (b - a).cross(q - a).dot(n) >= 0 && (c - b).cross(q - b).dot(n) >= 0 &&
                  (a - c).cross(q - c).dot(n) >= 0;
  if (in) return std::abs((p - a).dot(n));
  return std::min({seg_dist(p, a, b), seg_dist(p, b, c), seg_dist(p, c, a)});
}
double brute_distance(const Mesh& m, const Vector3d& p) {
  double best = 1e300;
  for (int f = 0; f < m.faces.rows(); ++f)
    best = std::min(best, tri_dist(p, m.vertices.row(m.faces(f, 0)), m.vertices.row(m.faces(f, 1)),
                                   m.vertices.row(m.faces(f, 2))));
  return best;
}
// Analytic signed distance to the box [-h, h] (per axis).
double box_sd(const Vector3d& p, const Vector3d& h) {
  const Vector3d q = p.cwiseAbs() - h;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}
// Convex polyhedron: signed plane distances of p to every face (max < 0 means inside).
double max_plane(const Mesh& m, const Vector3d& p) {
  double mx = -1e300;
  for (int f = 0; f < m.faces.rows(); ++f) {
    const Vector3d a = m.vertices.row(m.faces(f, 0)), b = m.vertices.row(m.faces(f, 1)),
                   c = m.vertices.row(m.faces(f, 2));
    mx = std::max(mx, (p - a).dot((b - a).cross(c - a).normalized()));
  }
  return mx;
}
// Ray entry into a convex polyhedron by clipping against every face plane (Cyrus-Beck).
bool convex_ray(const Mesh& m, const Vector3d& o, const Vector3d& d, double& t_in, double& t_out) {
  t_in = 0.0;
  t_out = 1e300;
  for (int f = 0; f < m.faces.rows(); ++f) {
    const Vector3d a = m.vertices.row(m.faces(f, 0)), b = m.vertices.row(m.faces(f, 1)),
                   c = m.vertices.row(m.faces(f, 2));
    const Vector3d n = (b - a).cross(c - a).normalized();
    const double num = (a - o).dot(n), den = d.dot(n);
    if (std::abs(den) < 1e-15) {
      if (num < 0) return false;
      continue;
    }
    const double t = num / den;
    if (den < 0) t_in = std::max(t_in, t);
    else t_out = std::min(t_out, t);
  }
  return t_in <= t_out;
}

}  // namespace

TEST(SurfaceQuery, ClosestMatchesBruteForceOnSphere) {
  const Mesh m = tmesh::icosphere(0.05, 3);  // 1280 faces
  const SurfaceQuery q(m);
  EXPECT_TRUE(q.closed());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.09, 0.09);
  for (int i = 0; i < 400; ++i) {
    const Vector3d p(u(rng), u(rng), u(rng));
    const SurfacePoint c = q.closest(p);
    const double ref = brute_distance(m, p);
    ASSERT_NEAR(c.distance, ref, 1e-12) << "point " << p.transpose();
    // The reported point is on the reported face, and the distance is to that point.
    ASSERT_NEAR((c.point - p).norm(), c.distance, 1e-12);
    const Vector3d a = m.vertices.row(m.faces(c.face, 0)), b = m.vertices.row(m.faces(c.face, 1)),
                   cc = m.vertices.row(m.faces(c.face, 2));
    ASSERT_NEAR(tri_dist(c.point, a, b, cc), 0.0, 1e-12);
    // The normal is that face's unit outward normal: on a sphere about 0, it points away from 0.
    ASSERT_NEAR(c.normal.norm(), 1.0, 1e-12);
    ASSERT_GT(c.normal.dot(a), 0.0);
  }
}

TEST(SurfaceQuery, BoundedClosestReportsNothingBeyondTheBound) {
  const Mesh m = tmesh::box_mesh(Vector3d(-0.05, -0.05, -0.05), Vector3d(0.05, 0.05, 0.05), 3);
  const SurfaceQuery q(m);
  const Vector3d p(0.08, 0.0, 0.0);  // 30 mm from the +x face
  EXPECT_EQ(q.closest(p, 0.029).face, -1);
  EXPECT_TRUE(std::isinf(q.closest(p, 0.029).distance));
  const SurfacePoint c = q.closest(p, 0.031);
  EXPECT_GE(c.face, 0);
  EXPECT_NEAR(c.distance, 0.03, 1e-12);
  EXPECT_NEAR(c.normal.x(), 1.0, 1e-12);
}

TEST(SurfaceQuery, SignedDistanceAndInsideMatchAnalyticBox) {
  const Vector3d h(0.05, 0.03, 0.02);
  const Mesh m = tmesh::box_mesh(-h, h, 4);
  const SurfaceQuery q(m);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-0.08, 0.08);
  int inside = 0;
  for (int i = 0; i < 3000; ++i) {
    const Vector3d p(u(rng), u(rng), u(rng));
    const double ref = box_sd(p, h);
    ASSERT_NEAR(q.signed_distance(p), ref, 1e-12) << p.transpose();
    ASSERT_EQ(q.inside(p), ref <= 0) << p.transpose();
    inside += ref < 0;
  }
  EXPECT_GT(inside, 50);
  // A grid aligned with the mesh's vertices and edges (x, y, z on the box's planes and on the
  // grid lines of its faces): closest points fall on edges and vertices, where the sign comes
  // from edge and vertex pseudo-normals.
  for (double x = -0.07; x <= 0.0701; x += 0.0125)
    for (double y = -0.045; y <= 0.0451; y += 0.0075)
      for (double z = -0.04; z <= 0.0401; z += 0.005) {
        const Vector3d p(x, y, z);
        const double ref = box_sd(p, h);
        ASSERT_NEAR(q.signed_distance(p), std::abs(ref) < 1e-12 ? 0.0 : ref, 1e-12) << p.transpose();
        ASSERT_EQ(q.inside(p), ref <= 1e-12) << p.transpose();
      }
}

TEST(SurfaceQuery, PointsOnTheSurfaceAreInsideWithZeroDistance) {
  const Vector3d h(0.05, 0.05, 0.05);
  const Mesh m = tmesh::box_mesh(-h, h, 2);
  const SurfaceQuery q(m);
  for (int i = 0; i < m.vertices.rows(); ++i) {  // every vertex
    EXPECT_TRUE(q.inside(Vector3d(m.vertices.row(i))));
    EXPECT_EQ(q.signed_distance(Vector3d(m.vertices.row(i))), 0.0);
  }
  for (const Vector3d p : {Vector3d(0.05, 0.01, -0.02), Vector3d(0.05, 0.05, 0.013),
                           Vector3d(-0.011, -0.05, 0.05), Vector3d(0.0, 0.0, -0.05)}) {
    EXPECT_TRUE(q.inside(p)) << p.transpose();
    EXPECT_EQ(q.signed_distance(p), 0.0) << p.transpose();
    EXPECT_LT(q.distance(p), 1e-15);
  }
}

TEST(SurfaceQuery, InsideAndDistanceOnConvexPolyhedron) {
  const Mesh m = tmesh::icosphere(0.04, 2, Vector3d(0.01, -0.02, 0.03));
  const SurfaceQuery q(m);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.06, 0.06);
  for (int i = 0; i < 2000; ++i) {
    const Vector3d p = Vector3d(0.01, -0.02, 0.03) + Vector3d(u(rng), u(rng), u(rng));
    const double plane = max_plane(m, p);
    if (std::abs(plane) < 1e-10) continue;
    ASSERT_EQ(q.inside(p), plane < 0) << p.transpose();
    // Inside a convex polyhedron the distance to the surface is the nearest face plane.
    if (plane < 0) ASSERT_NEAR(q.signed_distance(p), plane, 1e-12);
    else ASSERT_NEAR(q.signed_distance(p), brute_distance(m, p), 1e-12);
  }
}

TEST(SurfaceQuery, HollowBoxCavityIsOutside) {
  // A box with a box-shaped cavity (inner walls face into the cavity).
  const Mesh outer = tmesh::box_mesh(Vector3d(-0.05, -0.05, -0.05), Vector3d(0.05, 0.05, 0.05), 2);
  const Mesh inner = tmesh::box_mesh(Vector3d(-0.03, -0.03, -0.03), Vector3d(0.03, 0.03, 0.03), 2,
                                  "cavity", /*inward=*/true);
  const Mesh m = tmesh::merge(outer, inner, "hollow box");
  ASSERT_TRUE(m.closed);
  const SurfaceQuery q(m);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.07, 0.07);
  for (int i = 0; i < 2000; ++i) {
    const Vector3d p(u(rng), u(rng), u(rng));
    const double so = box_sd(p, Vector3d::Constant(0.05)), si = box_sd(p, Vector3d::Constant(0.03));
    const double ref = std::max(so, -si);  // solid = outer minus inner
    ASSERT_NEAR(q.signed_distance(p), ref, 1e-12) << p.transpose();
    ASSERT_EQ(q.inside(p), ref <= 0) << p.transpose();
  }
  EXPECT_FALSE(q.inside(Vector3d(0.0, 0.0, 0.0)));
  EXPECT_NEAR(q.signed_distance(Vector3d(0.0, 0.0, 0.0)), 0.03, 1e-12);
}

TEST(SurfaceQuery, PinchedVertexFallsBackToParity) {
  // Two cubes touching at one corner: closed (every edge has two faces) but the shared vertex's
  // faces form two fans and its pseudo-normal cancels out. Points around it must still be right.
  const Mesh a = tmesh::box_mesh(Vector3d(-0.02, -0.02, -0.02), Vector3d(0, 0, 0), 1, "a");
  const Mesh b = tmesh::box_mesh(Vector3d(0, 0, 0), Vector3d(0.02, 0.02, 0.02), 1, "b");
  Points V(a.vertices.rows() + b.vertices.rows(), 3);
  V << a.vertices, b.vertices;
  Triangles F(a.faces.rows() + b.faces.rows(), 3);
  F << a.faces, (b.faces.array() + static_cast<int>(a.vertices.rows())).matrix();
  MeshLoadOptions opt;
  opt.orient = false;  // weld the shared corner (default tolerance) but keep the winding
  const Mesh m = make_mesh(V, F, "pinched", opt);
  ASSERT_EQ(m.vertices.rows(), 15);  // 16 corners, the shared one welded
  ASSERT_TRUE(m.closed);
  const SurfaceQuery q(m);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-0.004, 0.004);
  int tested = 0;
  for (int i = 0; i < 2000; ++i) {
    const Vector3d p(u(rng), u(rng), u(rng));
    const double ref = std::min(box_sd(p + Vector3d::Constant(0.01), Vector3d::Constant(0.01)),
                                box_sd(p - Vector3d::Constant(0.01), Vector3d::Constant(0.01)));
    if (std::abs(ref) < 1e-12) continue;
    ASSERT_EQ(q.inside(p), ref < 0) << p.transpose();
    ASSERT_NEAR(std::abs(q.signed_distance(p)), std::abs(ref), 1e-12);
    ++tested;
  }
  EXPECT_GT(tested, 1900);
}

TEST(SurfaceQuery, RayCastMatchesAnalyticBox) {
  const Vector3d h(0.05, 0.03, 0.02);
  const Mesh m = tmesh::box_mesh(-h, h, 3);
  const SurfaceQuery q(m);
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int hits = 0;
  for (int i = 0; i < 2000; ++i) {
    const Vector3d o = 0.1 * Vector3d(u(rng), u(rng), u(rng));
    const Vector3d d = Vector3d(u(rng), u(rng), u(rng)) * 3.0;  // not unit: t is metres anyway
    const Vector3d dn = d.normalized();
    // Slab method, independent of the tree.
    double t0 = 0.0, t1 = 1e300;
    for (int k = 0; k < 3; ++k) {
      double a = (-h[k] - o[k]) / dn[k], b = (h[k] - o[k]) / dn[k];
      if (a > b) std::swap(a, b);
      t0 = std::max(t0, a);
      t1 = std::min(t1, b);
    }
    const bool inside = box_sd(o, h) < 0;
    const bool expect_hit = t0 <= t1;
    const auto hit = q.ray_cast(o, d);
    ASSERT_EQ(hit.has_value(), expect_hit) << o.transpose() << " / " << dn.transpose();
    if (!expect_hit) continue;
    ++hits;
    const double t_ref = inside ? t1 : t0;
    ASSERT_NEAR(hit->t, t_ref, 1e-12);
    ASSERT_NEAR((hit->point - (o + dn * t_ref)).norm(), 0.0, 1e-12);
    ASSERT_NEAR(std::abs(box_sd(hit->point, h)), 0.0, 1e-12);
    // All hits: one when starting inside, two (entry, exit) from outside -- barring rays that
    // cross an edge of the triangulation, where both triangles report the point.
    const auto all = q.ray_hits(o, d);
    ASSERT_GE(all.size(), inside ? 1u : 2u);
    ASSERT_NEAR(all.front().t, t_ref, 1e-12);
    ASSERT_NEAR(all.back().t, t1, 1e-12);
    for (size_t k = 1; k < all.size(); ++k) ASSERT_LE(all[k - 1].t, all[k].t);
    // A bound shorter than the hit finds nothing.
    ASSERT_FALSE(q.ray_cast(o, d, t_ref * 0.999).has_value());
    ASSERT_EQ(q.ray_blocked(o, d, t_ref * 1.001), true);
    ASSERT_EQ(q.ray_blocked(o, d, t_ref * 0.999), false);
  }
  EXPECT_GT(hits, 150);
}

TEST(SurfaceQuery, RayCastMatchesConvexClipping) {
  const Mesh m = tmesh::icosphere(0.05, 2);
  const SurfaceQuery q(m);
  std::mt19937 rng(17);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int i = 0; i < 1000; ++i) {
    const Vector3d o = 0.15 * Vector3d(g(rng), g(rng), g(rng)).normalized();
    const Vector3d d = (0.03 * Vector3d(g(rng), g(rng), g(rng)) - o).normalized();
    double t_in, t_out;
    const bool ref = convex_ray(m, o, d, t_in, t_out);
    const auto hit = q.ray_cast(o, d);
    if (ref && t_out - t_in < 1e-9) continue;  // grazing: either answer is fine
    ASSERT_EQ(hit.has_value(), ref);
    if (ref) ASSERT_NEAR(hit->t, t_in, 1e-12);
  }
}

TEST(SurfaceQuery, TriangleDistanceToBox) {
  const Mesh m = tmesh::box_mesh(Vector3d(-0.05, -0.05, -0.05), Vector3d(0.05, 0.05, 0.05), 2);
  const SurfaceQuery q(m);
  // A triangle 7 mm above the top face, tilted so its lowest corner sets the distance.
  EXPECT_NEAR(q.triangle_distance(Vector3d(0, 0, 0.057), Vector3d(0.02, 0, 0.08), Vector3d(0, 0.02, 0.09)),
              0.007, 1e-12);
  // One crossing the +x face: distance 0.
  EXPECT_EQ(q.triangle_distance(Vector3d(0.04, 0, 0), Vector3d(0.07, 0.01, 0), Vector3d(0.07, -0.01, 0.01)), 0.0);
  // Beside an edge: distance to the edge line x = y = 0.05.
  const double d = q.triangle_distance(Vector3d(0.06, 0.06, 0), Vector3d(0.08, 0.06, 0.01), Vector3d(0.06, 0.08, -0.01));
  EXPECT_NEAR(d, std::sqrt(2.0) * 0.01, 1e-12);
  // Bounded: beyond the bound it is inf.
  EXPECT_TRUE(std::isinf(q.triangle_distance(Vector3d(0, 0, 0.057), Vector3d(0.02, 0, 0.08),
                                             Vector3d(0, 0.02, 0.09), 0.005)));
}

TEST(SurfaceQuery, BatchesEqualSingleQueriesForAnyThreadCount) {
  const Mesh m = tmesh::icosphere(0.05, 3);
  const SurfaceQuery q(m);
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> u(-0.08, 0.08);
  Points P(500, 3), D(500, 3);
  for (int i = 0; i < 500; ++i) {
    P.row(i) << u(rng), u(rng), u(rng);
    D.row(i) << u(rng), u(rng), u(rng);
  }
  for (int threads : {1, 3}) {
    const SurfacePoints c = q.batch_closest(P, threads);
    const Eigen::VectorXd sd = q.batch_signed_distance(P, threads);
    const Mask in = q.batch_inside(P, threads);
    const RayHits r = q.batch_ray_cast(P, D, threads);
    for (int i = 0; i < 500; ++i) {
      const Vector3d p = P.row(i);
      const SurfacePoint s = q.closest(p);
      ASSERT_EQ(c.faces[i], s.face);
      ASSERT_EQ(c.distances[i], s.distance);
      ASSERT_EQ(Vector3d(c.points.row(i)), s.point);
      ASSERT_EQ(sd[i], q.signed_distance(p));
      ASSERT_EQ(in[i], q.inside(p));
      const auto h = q.ray_cast(p, D.row(i).transpose());
      ASSERT_EQ(r.faces[i], h ? h->face : -1);
      if (h) ASSERT_EQ(r.t[i], h->t);
      else ASSERT_TRUE(std::isinf(r.t[i]));
    }
  }
}

TEST(SurfaceQuery, BadInputThrows) {
  const Mesh box = tmesh::box_mesh(Vector3d(-1, -1, -1), Vector3d(1, 1, 1));
  const SurfaceQuery q(box);
  const double nan = std::nan("");
  EXPECT_THROW(q.closest(Vector3d(nan, 0, 0)), std::invalid_argument);
  EXPECT_THROW(q.inside(Vector3d(0, std::numeric_limits<double>::infinity(), 0)), std::invalid_argument);
  EXPECT_THROW(q.ray_cast(Vector3d::Zero(), Vector3d::Zero()), std::invalid_argument);
  EXPECT_THROW(q.ray_cast(Vector3d::Zero(), Vector3d(1, 0, 0), -1.0), std::invalid_argument);
  EXPECT_THROW(q.closest(Vector3d::Zero(), -1.0), std::invalid_argument);
  Points P(2, 3);
  P << 0, 0, 0, nan, 0, 0;
  try {
    q.batch_signed_distance(P);
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("points: row 1"), std::string::npos) << e.what();
  }
  EXPECT_THROW(q.batch_ray_cast(P.topRows(1), Points::Zero(2, 3)), std::invalid_argument);
  // An open mesh (a box without its top) has no inside.
  Triangles F = box.faces.topRows(box.faces.rows() - 2);
  const Mesh open = make_mesh(box.vertices, F, "open box");
  ASSERT_FALSE(open.closed);
  const SurfaceQuery qo(open);
  try {
    qo.inside(Vector3d::Zero());
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("not closed"), std::string::npos) << e.what();
  }
  EXPECT_THROW(qo.signed_distance(Vector3d::Zero()), std::invalid_argument);
  EXPECT_NO_THROW(qo.closest(Vector3d::Zero()));  // distances are defined for any mesh
  EXPECT_THROW(SurfaceQuery(Mesh{}), std::invalid_argument);
}

// ---------------------------------------------------------------- per-face free masks (free_surface.hpp)

#include <pairgrasp/free_surface.hpp>

namespace {
double face_coord(const Mesh& m, int f, int axis, bool max) {
  double v = m.vertices(m.faces(f, 0), axis);
  for (int k = 1; k < 3; ++k)
    v = max ? std::max(v, m.vertices(m.faces(f, k), axis)) : std::min(v, m.vertices(m.faces(f, k), axis));
  return v;
}
Vector3d face_normal_of(const Mesh& m, int f) {
  const Vector3d a = m.vertices.row(m.faces(f, 0)), b = m.vertices.row(m.faces(f, 1)),
                 c = m.vertices.row(m.faces(f, 2));
  return (b - a).cross(c - a).normalized();
}
}  // namespace

TEST(FaceMasks, SlabOccludesExactlyTheFacesWithinReach) {
  // A 0.1 m cube in 1 cm squares; a slab z in [0.03, 0.2] much wider than the cube cuts its top.
  const Mesh target = tmesh::box_mesh(Vector3d::Constant(-0.05), Vector3d::Constant(0.05), 10, "cube");
  const Mesh slab = tmesh::box_mesh(Vector3d(-0.2, -0.2, 0.03), Vector3d(0.2, 0.2, 0.2), 1, "slab");
  for (double d : {0.0, 0.005, 0.012}) {
    const Mask free = occluded_by(target, {slab}, d);
    ASSERT_EQ(free.size(), target.faces.rows());
    int occluded = 0;
    for (int f = 0; f < target.faces.rows(); ++f) {
      // The slab's underside z = 0.03 spans the cube, so a face is within d of the slab exactly
      // when its highest point reaches z >= 0.03 - d (faces above lie inside the slab).
      const bool expect_free = face_coord(target, f, 2, true) < 0.03 - d - 1e-12;
      ASSERT_EQ(free[f], expect_free) << "face " << f << " d = " << d;
      occluded += !expect_free;
    }
    EXPECT_GT(occluded, 200);  // the top (200 faces) and bands of the four sides
  }
}

TEST(FaceMasks, OpenOccluderOccludesByDistanceOnly) {
  const Mesh target = tmesh::box_mesh(Vector3d::Constant(-0.05), Vector3d::Constant(0.05), 10, "cube");
  Points V(4, 3);
  V << -0.2, -0.2, 0.03, 0.2, -0.2, 0.03, 0.2, 0.2, 0.03, -0.2, 0.2, 0.03;
  Triangles F(2, 3);
  F << 0, 1, 2, 0, 2, 3;
  const Mesh plane = make_mesh(V, F, "plane");
  ASSERT_FALSE(plane.closed);
  const double d = 0.005;
  const Mask free = occluded_by(target, {plane}, d);
  for (int f = 0; f < target.faces.rows(); ++f) {
    const double lo = face_coord(target, f, 2, false), hi = face_coord(target, f, 2, true);
    const bool near = hi >= 0.03 - d - 1e-12 && lo <= 0.03 + d + 1e-12;
    ASSERT_EQ(free[f], !near) << "face " << f;
  }
  // The incoming mask is ANDed in.
  Mask start = Mask::Constant(target.faces.rows(), true);
  start[0] = false;
  EXPECT_FALSE(occluded_by(target, {plane}, d, start)[0]);
}

TEST(FaceMasks, VisibleFromMarksTheBackSideOccluded) {
  const Mesh target = tmesh::box_mesh(Vector3d::Constant(-0.05), Vector3d::Constant(0.05), 2, "cube");
  Points eye(1, 3);
  eye << 1.0, 0.0, 0.0;
  Mask free = visible_from(target, eye);
  for (int f = 0; f < target.faces.rows(); ++f)
    ASSERT_EQ(free[f], face_normal_of(target, f).x() > 0.5) << "face " << f;
  Points eyes(2, 3);
  eyes << 1.0, 0.0, 0.0, 0.0, 0.0, 1.0;  // two viewpoints: +x and +z faces seen
  free = visible_from(target, eyes);
  for (int f = 0; f < target.faces.rows(); ++f) {
    const Vector3d n = face_normal_of(target, f);
    ASSERT_EQ(free[f], n.x() > 0.5 || n.z() > 0.5) << "face " << f;
  }
}

TEST(FaceMasks, VisibleFromAccountsForSelfOcclusionAndOccluders) {
  // Two boxes in one mesh: the small one sits behind the big one seen from -x.
  const Mesh big = tmesh::box_mesh(Vector3d::Constant(-0.05), Vector3d::Constant(0.05), 1, "big");
  const Mesh small = tmesh::box_mesh(Vector3d(0.2, -0.02, -0.02), Vector3d(0.3, 0.02, 0.02), 1, "small");
  const Mesh target = tmesh::merge(big, small, "two boxes");
  Points eye(1, 3);
  eye << -1.0, 0.0, 0.0;
  const Mask free = visible_from(target, eye);
  for (int f = 0; f < target.faces.rows(); ++f) {
    const bool on_big = f < big.faces.rows();
    ASSERT_EQ(free[f], on_big && face_normal_of(target, f).x() < -0.5) << "face " << f;
  }
  // An occluder wall between the eye and the target hides everything: an error that says so.
  const Mesh wall = tmesh::box_mesh(Vector3d(-0.5, -0.5, -0.5), Vector3d(-0.4, 0.5, 0.5), 1, "wall");
  try {
    visible_from(target, eye, Mask(), {wall});
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("no free face left: ", 0), 0u) << e.what();
  }
}

TEST(FaceMasks, BadInputAndEmptyResultsThrow) {
  const Mesh target = tmesh::box_mesh(Vector3d::Constant(-0.05), Vector3d::Constant(0.05), 1, "cube");
  const Mesh huge = tmesh::box_mesh(Vector3d::Constant(-1), Vector3d::Constant(1), 1, "huge");
  auto expect_msg = [](auto&& fn, const std::string& start) {
    try {
      fn();
      FAIL() << "expected invalid_argument starting with " << start;
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind(start, 0), 0u) << e.what();
    }
  };
  expect_msg([&] { occluded_by(target, {huge}, 0.0); }, "no free face left: ");  // target inside
  expect_msg([&] { occluded_by(target, {huge}, -1.0); }, "distance: ");
  expect_msg([&] { occluded_by(target, {huge}, std::nan("")); }, "distance: ");
  expect_msg([&] { occluded_by(target, {}, 0.0, Mask::Constant(3, true)); }, "free: expected 12, got 3");
  expect_msg([&] { occluded_by(target, {}, 0.0, Mask::Constant(12, false)); }, "no free face left: ");
  expect_msg([&] { visible_from(target, Points(0, 3)); }, "viewpoints: ");
  Points bad(1, 3);
  bad << 0, std::nan(""), 0;
  expect_msg([&] { visible_from(target, bad); }, "viewpoints: row 0");
  Points inside(1, 3);
  inside << 0, 0, 0;  // an eye inside the box sees only back faces
  expect_msg([&] { visible_from(target, inside); }, "no free face left: ");
  expect_msg([&] { combine_free(Mask::Constant(12, true), Mask::Constant(11, true)); }, "b: expected 12, got 11");
  Mask a = Mask::Constant(12, false), b = Mask::Constant(12, false);
  a[3] = true;
  b[4] = true;
  expect_msg([&] { combine_free(a, b); }, "no free face left: ");
  b[3] = true;
  const Mask c = combine_free(a, b);
  EXPECT_EQ(c.count(), 1);
  EXPECT_TRUE(c[3]);
}

// ---------------------------------------------------------------- surface sampling (internal)

#include "../../cpp/src/surface_query_internal.hpp"

TEST(SurfaceSampling, CoversEveryFaceWithinTheSpacingWithoutOversamplingThinFaces) {
  // A cylinder-like fan of long thin triangles (100 mm x ~5 mm) and a sphere.
  const int segments = 64;
  const double r = 0.04, h = 0.1;
  Points V(2 * segments, 3);
  Triangles F(2 * segments, 3);
  for (int k = 0; k < segments; ++k) {
    const double a = 2 * M_PI * k / segments;
    V.row(k) << r * std::cos(a), r * std::sin(a), 0.0;
    V.row(segments + k) << r * std::cos(a), r * std::sin(a), h;
    const int k1 = (k + 1) % segments;
    F.row(2 * k) << k, k1, segments + k1;
    F.row(2 * k + 1) << k, segments + k1, segments + k;
  }
  const Mesh tube = make_mesh(V, F, "tube");
  const Mesh ball = tmesh::icosphere(0.05, 2);
  for (const Mesh* m : {&tube, &ball}) {
    for (double s : {0.002, 0.005}) {
      std::vector<int> owner;
      const Points S = pairgrasp::geometry_detail::sample_surface(m->vertices, m->faces, {}, s, &owner);
      ASSERT_EQ(static_cast<Eigen::Index>(owner.size()), S.rows());
      // Count: about area / s^2 (a barycentric grid on these 100 mm faces would give 20x more).
      double edges = 0;
      for (int f = 0; f < m->faces.rows(); ++f)
        for (int k = 0; k < 3; ++k)
          edges += 0.5 * (m->vertices.row(m->faces(f, k)) - m->vertices.row(m->faces(f, (k + 1) % 3))).norm();
      EXPECT_LT(S.rows(), m->area / (s * s) + edges / s + m->vertices.rows() + 1) << m->source << " " << s;
      EXPECT_GT(S.rows(), 0.5 * m->area / (s * s)) << m->source << " " << s;
      // Every sample lies on its face.
      for (Eigen::Index i = 0; i < S.rows(); ++i) {
        const int f = owner[i];
        ASSERT_LT(tri_dist(S.row(i).transpose(), m->vertices.row(m->faces(f, 0)), m->vertices.row(m->faces(f, 1)),
                           m->vertices.row(m->faces(f, 2))),
                  1e-12);
      }
      // Coverage: random surface points (area-weighted faces, uniform barycentric) are within
      // 1.5 s of a sample.
      std::mt19937 rng(4);
      std::uniform_real_distribution<double> u(0, 1);
      std::vector<double> weights;
      for (int f = 0; f < m->faces.rows(); ++f) weights.push_back(m->face_area(f));
      std::discrete_distribution<int> pick(weights.begin(), weights.end());
      double worst = 0;
      for (int t = 0; t < 300; ++t) {
        const int f = pick(rng);
        double x = u(rng), y = u(rng);
        if (x + y > 1) x = 1 - x, y = 1 - y;
        const Vector3d a = m->vertices.row(m->faces(f, 0)), b = m->vertices.row(m->faces(f, 1)),
                       c = m->vertices.row(m->faces(f, 2));
        const Vector3d q = a + x * (b - a) + y * (c - a);
        worst = std::max(worst, (S.rowwise() - q.transpose()).rowwise().norm().minCoeff());
      }
      EXPECT_LE(worst, 1.5 * s) << m->source << " " << s;
    }
  }
}
