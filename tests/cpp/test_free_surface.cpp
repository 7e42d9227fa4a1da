// The free surface per patch (free_surface.hpp): a coarse box on a table keeps its sides free above
// the covered strip; the refined mesh is the same closed surface; the support plane and a table mesh
// give the same free surface; paint regions mark points, not face centroids; bad input throws. And
// where on the free surface a force-closure grasp can be at all (graspable.hpp).
#include <pairgrasp/free_surface.hpp>
#include <pairgrasp/graspable.hpp>
#include <pairgrasp/planner.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <utility>

#include "test_hands.hpp"
#include "test_meshes.hpp"

namespace {

using namespace pairgrasp;
namespace tmesh = pairgrasp::testing_meshes;
using Eigen::Vector3d;

constexpr double kHalf = 0.05;  // the box is 10 cm on a side, its bottom at z = -5 cm
constexpr double kRes = 0.0025;
constexpr double kDist = 0.005;

Mesh coarse_box() { return tmesh::box_mesh(Vector3d::Constant(-kHalf), Vector3d::Constant(kHalf), 1, "box"); }

Vector3d corner(const Mesh& m, int f, int k) { return m.vertices.row(m.faces(f, k)).transpose(); }

double face_area(const Mesh& m, int f) {
  return 0.5 * (corner(m, f, 1) - corner(m, f, 0)).cross(corner(m, f, 2) - corner(m, f, 0)).norm();
}

// Signed volume by the divergence theorem (independent of the library's mesh code).
double volume(const Mesh& m) {
  double v = 0.0;
  for (int f = 0; f < m.faces.rows(); ++f) v += corner(m, f, 0).dot(corner(m, f, 1).cross(corner(m, f, 2))) / 6.0;
  return v;
}

double area(const Mesh& m, const Mask* only = nullptr) {
  double a = 0.0;
  for (int f = 0; f < m.faces.rows(); ++f)
    if (!only || (*only)[f]) a += face_area(m, f);
  return a;
}

// Every undirected edge used by exactly two faces, once in each direction: closed, no T-junction.
void expect_closed(const Mesh& m) {
  std::map<std::pair<int, int>, int> directed;
  for (int f = 0; f < m.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) ++directed[{m.faces(f, k), m.faces(f, (k + 1) % 3)}];
  for (const auto& [e, n] : directed) {
    ASSERT_EQ(n, 1) << "edge " << e.first << "-" << e.second << " used twice in one direction";
    ASSERT_EQ(directed.count({e.second, e.first}), 1u) << "edge " << e.first << "-" << e.second << " is a border";
  }
}

double min_height(const Mesh& m, int f) {
  return std::min({corner(m, f, 0).z(), corner(m, f, 1).z(), corner(m, f, 2).z()}) + kHalf;
}
double max_height(const Mesh& m, int f) {
  return std::max({corner(m, f, 0).z(), corner(m, f, 1).z(), corner(m, f, 2).z()}) + kHalf;
}

Occlusion on_plane() {
  Occlusion o;
  o.support = SupportPlane::below(coarse_box());
  o.distance = kDist;
  return o;
}

TEST(FreeSurface, CoarseBoxOnATableKeepsItsSidesFreeAboveTheCoveredStrip) {
  const Mesh box = coarse_box();
  const Occlusion o = on_plane();
  EXPECT_NEAR(o.support->point.z(), -kHalf, 1e-12);
  const FreeSurface s = free_surface(box, o, kRes, 1);
  // The 8 side triangles run from the table up: divided. The bottom lies on it (wholly occluded), the
  // top clears it (wholly free); they are cut only where a split side's edge runs (conforming).
  EXPECT_GE(s.split_faces, 8);
  EXPECT_LE(s.split_faces, 12);
  EXPECT_GT(s.mesh.faces.rows(), 12);
  EXPECT_LE(s.resolution, kRes);
  ASSERT_EQ(s.free.size(), s.mesh.faces.rows());
  ASSERT_EQ(s.source_faces.size(), s.mesh.faces.rows());
  expect_closed(s.mesh);
  EXPECT_NEAR(volume(s.mesh), 1e-3, 1e-12);
  EXPECT_NEAR(area(s.mesh), 0.06, 1e-12);
  for (int f = 0; f < s.mesh.faces.rows(); ++f) {
    // No free point lies within the distance of the table; an occluded patch lies within the distance
    // plus one patch of it.
    if (s.free[f])
      EXPECT_GT(min_height(s.mesh, f), kDist) << "face " << f;
    else
      EXPECT_LE(max_height(s.mesh, f), kDist + kRes + 1e-12) << "face " << f;
    // Each piece lies in its source face's plane.
    const int src = s.source_faces[f];
    const Vector3d n0 = (corner(box, src, 1) - corner(box, src, 0)).cross(corner(box, src, 2) - corner(box, src, 0));
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(n0.normalized().dot(corner(s.mesh, f, k) - corner(box, src, 0)), 0.0, 1e-12);
  }
  // The side area more than distance + resolution above the table is all free: 4 sides of
  // 10 cm x (10 cm - 7.5 mm), plus the top.
  const double sure = 4 * 2 * kHalf * (2 * kHalf - kDist - kRes) + 4 * kHalf * kHalf;
  const double free_area = area(s.mesh, &s.free);
  EXPECT_GE(free_area, sure - 1e-12);
  EXPECT_LE(free_area, 4 * 2 * kHalf * (2 * kHalf - kDist) + 4 * kHalf * kHalf + 1e-12);
  // Per face (the old way) every side face touches the table and is occluded: only the top is free.
  const FreeSurface whole = free_surface(box, o);
  EXPECT_EQ(whole.split_faces, 0);
  EXPECT_EQ(whole.free.count(), 2);
  // Deterministic, whatever the threads.
  const FreeSurface again = free_surface(box, o, kRes, 2);
  EXPECT_TRUE(again.mesh.vertices == s.mesh.vertices);
  EXPECT_TRUE(again.mesh.faces == s.mesh.faces);
  EXPECT_TRUE(again.free == s.free);
}

TEST(FreeSurface, PiecesGrowWithTheBoundaryNotWithTheArea) {
  // A 1 cm x 1 cm x 20 cm column of 12 triangles standing on the table (its bottom at z = -5 cm):
  // each side is two 1 cm x 20 cm triangles that the covered strip's top edge crosses. The mark
  // changes along 4 cm of surface, 16 patches of the resolution; cutting the long faces across their
  // length keeps the pieces to a small multiple of that (cutting every edge in half, as a uniform
  // subdivision does, gave 4,076 pieces).
  const Mesh column = tmesh::box_mesh(Vector3d(-0.005, -0.005, -kHalf), Vector3d(0.005, 0.005, 0.15), 1, "column");
  Occlusion o;
  o.support = SupportPlane::below(column);
  o.distance = kDist;
  const FreeSurface s = free_surface(column, o, kRes, 1);
  EXPECT_LT(s.mesh.faces.rows(), 12 + 40 * 0.04 / kRes);
  expect_closed(s.mesh);
  EXPECT_NEAR(volume(s.mesh), 0.01 * 0.01 * 0.2, 1e-12);
  double free_area = 0.0;
  for (int f = 0; f < s.mesh.faces.rows(); ++f) {
    if (s.free[f]) {
      EXPECT_GT(min_height(s.mesh, f), kDist) << "face " << f;
      free_area += face_area(s.mesh, f);
    } else {
      EXPECT_LE(max_height(s.mesh, f), kDist + kRes + 1e-12) << "face " << f;
    }
  }
  // Every side point more than distance + resolution above the table is free, and the top.
  EXPECT_GE(free_area, 4 * 0.01 * (0.2 - kDist - kRes) + 1e-4 - 1e-12);
  EXPECT_LE(free_area, 4 * 0.01 * (0.2 - kDist) + 1e-4 + 1e-12);
}

TEST(FreeSurface, SupportPlaneAndTableMeshGiveTheSameFreeSurface) {
  const Mesh box = coarse_box();
  const FreeSurface plane = free_surface(box, on_plane(), kRes, 1);
  Occlusion table;
  table.distance = kDist;
  table.occluders = {tmesh::box_mesh(Vector3d(-0.3, -0.3, -kHalf - 0.02), Vector3d(0.3, 0.3, -kHalf), 1, "table")};
  const FreeSurface mesh = free_surface(box, table, kRes, 1);
  expect_closed(mesh.mesh);
  // The same classification everywhere: the table reaches past the box, so the distance from a side
  // point to it is its height.
  EXPECT_NEAR(area(mesh.mesh, &mesh.free), area(plane.mesh, &plane.free), 1e-12);
  EXPECT_EQ(mesh.free.count(), plane.free.count());
}

TEST(FreeSurface, TiltedSupportFollowsItsNormal) {
  // The box turned about x by 30 degrees rests on the plane through its lowest edge with normal z:
  // free patches clear that plane by more than the distance.
  Mesh box = coarse_box();
  const Eigen::Matrix3d R = Eigen::AngleAxisd(M_PI / 6, Vector3d::UnitX()).toRotationMatrix();
  box.vertices = (box.vertices * R.transpose()).eval();
  Occlusion o;
  o.support = SupportPlane::below(box, Vector3d(0, 0, 2));  // any length
  o.distance = kDist;
  const FreeSurface s = free_surface(box, o, kRes, 1);
  expect_closed(s.mesh);
  const double z0 = box.vertices.col(2).minCoeff();
  for (int f = 0; f < s.mesh.faces.rows(); ++f) {
    double lo = 1e9, hi = -1e9;
    for (int k = 0; k < 3; ++k) {
      lo = std::min(lo, corner(s.mesh, f, k).z() - z0);
      hi = std::max(hi, corner(s.mesh, f, k).z() - z0);
    }
    if (s.free[f])
      EXPECT_GT(lo, kDist) << "face " << f;
    else
      EXPECT_LE(hi, kDist + kRes + 1e-12) << "face " << f;
  }
  // Support height: what SupportPlane::height says of the lowest corner.
  EXPECT_NEAR(o.support->height(box.vertices.row(0).transpose()), box.vertices(0, 2) - z0, 1e-12);
}

TEST(FreeSurface, PaintRegionsMarkPointsNotCentroids) {
  // A half-space region occluding everything below z = 1 cm: the side faces' centroids lie on one
  // side or the other, but the split surface follows the plane to within a patch.
  const Mesh box = coarse_box();
  Occlusion o;
  o.regions = {PaintRegion::halfspace(Vector3d(0, 0, 0.01), Vector3d(0, 0, -1), false)};
  const FreeSurface s = free_surface(box, o, kRes, 1);
  expect_closed(s.mesh);
  const double exact = 4 * 2 * kHalf * (kHalf - 0.01) + 4 * kHalf * kHalf;  // sides above 1 cm, top
  EXPECT_NEAR(area(s.mesh, &s.free), exact, 4 * 2 * kHalf * kRes);
  for (int f = 0; f < s.mesh.faces.rows(); ++f) {
    const Vector3d c = (corner(s.mesh, f, 0) + corner(s.mesh, f, 1) + corner(s.mesh, f, 2)) / 3.0;
    if (std::abs(c.z() - 0.01) > kRes) EXPECT_EQ(bool(s.free[f]), c.z() > 0.01) << "face " << f;
  }
  // A paint mask marks whole faces: the top's two faces occluded stay occluded, unsplit.
  Occlusion p = o;
  p.paint = Mask::Constant(12, true);
  for (int f = 0; f < 12; ++f)
    if (corner(box, f, 0).z() == kHalf && corner(box, f, 1).z() == kHalf && corner(box, f, 2).z() == kHalf)
      p.paint[f] = false;
  const FreeSurface q = free_surface(box, p, kRes, 1);
  EXPECT_NEAR(area(q.mesh, &q.free), exact - 4 * kHalf * kHalf, 4 * 2 * kHalf * kRes);
}

TEST(FreeSurface, HolderAroundPartOfTheTargetCoversOnlyWhatItTouches) {
  // A ring of four slabs 5 mm away from the box's sides, around its upper half: within distance
  // 1 cm the sides above z = 0 are covered, the lower half and the bottom are free.
  const Mesh box = coarse_box();
  const double g = 0.005, t = 0.01;
  Mesh ring = tmesh::box_mesh(Vector3d(kHalf + g, -0.08, 0), Vector3d(kHalf + g + t, 0.08, 0.06), 1, "ring");
  for (const auto& [lo, hi] : {std::pair{Vector3d(-kHalf - g - t, -0.08, 0), Vector3d(-kHalf - g, 0.08, 0.06)},
                               std::pair{Vector3d(-0.08, kHalf + g, 0), Vector3d(0.08, kHalf + g + t, 0.06)},
                               std::pair{Vector3d(-0.08, -kHalf - g - t, 0), Vector3d(0.08, -kHalf - g, 0.06)}})
    ring = tmesh::merge(ring, tmesh::box_mesh(lo, hi, 1, "slab"), "ring");
  Occlusion o;
  o.occluders = {ring};
  o.distance = 0.01;
  const FreeSurface s = free_surface(box, o, kRes, 1);
  expect_closed(s.mesh);
  for (int f = 0; f < s.mesh.faces.rows(); ++f) {
    const Vector3d c = (corner(s.mesh, f, 0) + corner(s.mesh, f, 1) + corner(s.mesh, f, 2)) / 3.0;
    const bool side = std::abs(std::abs(c.x()) - kHalf) < 1e-9 || std::abs(std::abs(c.y()) - kHalf) < 1e-9;
    if (side && c.z() > kRes) EXPECT_FALSE(s.free[f]) << "face " << f;
    if (side && c.z() < -o.distance - kRes) EXPECT_TRUE(s.free[f]) << "face " << f;
    if (c.z() < -kHalf + 1e-9) EXPECT_TRUE(s.free[f]) << "bottom face " << f;
  }
}

TEST(FreeSurface, BadInputThrowsNamingTheField) {
  const Mesh box = coarse_box();
  auto expect_msg = [&](const Occlusion& o, double res, const std::string& start) {
    try {
      free_surface(box, o, res, 1);
      FAIL() << "expected invalid_argument starting with " << start;
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind(start, 0), 0u) << e.what();
    }
  };
  Occlusion o = on_plane();
  expect_msg(o, std::nan(""), "resolution: ");
  expect_msg(o, 0.0, "resolution: ");
  Occlusion cut = o;
  cut.support->point.z() = 0.0;  // through the middle of the box
  expect_msg(cut, kRes, "support: the plane cuts through the target");
  Occlusion nan_plane = o;
  nan_plane.support->normal.y() = std::nan("");
  expect_msg(nan_plane, kRes, "support: the plane's normal is not finite");
  Occlusion inf_point = o;
  inf_point.support->point.x() = std::numeric_limits<double>::infinity();
  expect_msg(inf_point, kRes, "support: the plane's point is not finite");
  Occlusion zero = o;
  zero.support->normal.setZero();
  expect_msg(zero, kRes, "support: the plane's normal is zero");
  Occlusion all = o;
  all.distance = 0.2;  // every point of a 10 cm box is within 20 cm of the table
  expect_msg(all, kRes, "no free face left: every part of 'box' is covered by the support within");
  Occlusion neg = o;
  neg.distance = -1e-3;
  expect_msg(neg, kRes, "distance: ");
  Occlusion paint = o;
  paint.paint = Mask::Constant(5, true);
  expect_msg(paint, kRes, "paint: expected 12, got 5");
  EXPECT_THROW(SupportPlane::below(box, Vector3d::Zero()), std::invalid_argument);
  EXPECT_THROW(SupportPlane::below(Mesh{}), std::invalid_argument);
  EXPECT_THROW(support_box(*o.support, box, 0.0), std::invalid_argument);
}

TEST(FreeSurface, ATableMeshIsRecognisedAsTheSupport) {
  const Mesh box = coarse_box();
  const Mesh table = tmesh::box_mesh(Vector3d(-0.3, -0.3, -kHalf - 0.02), Vector3d(0.3, 0.3, -kHalf), 1, "table");
  const std::optional<SupportPlane> s = SupportPlane::under(box, table, kDist);
  ASSERT_TRUE(s.has_value());
  EXPECT_NEAR(s->normal.normalized().z(), 1.0, 1e-12);
  EXPECT_NEAR(s->point.z(), -kHalf, 1e-12);
  // 3 mm below the box: still within the distance; 1 cm below: not standing on it.
  Mesh lower = table;
  lower.vertices.col(2).array() -= 0.003;
  EXPECT_TRUE(SupportPlane::under(box, lower, kDist).has_value());
  lower.vertices.col(2).array() -= 0.007;
  EXPECT_FALSE(SupportPlane::under(box, lower, kDist).has_value());
  // A wall the box leans on is one too (the hand must stay on this side of it), 2 cm away it is not.
  const std::optional<SupportPlane> wall = SupportPlane::under(
      box, tmesh::box_mesh(Vector3d(kHalf, -0.3, -0.3), Vector3d(kHalf + 0.02, 0.3, 0.3), 1, "wall"), kDist);
  ASSERT_TRUE(wall.has_value());
  EXPECT_NEAR(wall->normal.normalized().x(), -1.0, 1e-12);
  EXPECT_FALSE(SupportPlane::under(box, tmesh::box_mesh(Vector3d(kHalf + 0.02, -0.3, -0.3),
                                                        Vector3d(kHalf + 0.04, 0.3, 0.3), 1, "wall"), kDist));
  // A slab narrower than the box, a table cutting into it: not a support.
  EXPECT_FALSE(SupportPlane::under(box, tmesh::box_mesh(Vector3d(-0.02, -0.02, -kHalf - 0.02),
                                                        Vector3d(0.02, 0.02, -kHalf), 1, "slab"), kDist));
  EXPECT_FALSE(SupportPlane::under(box, tmesh::box_mesh(Vector3d(-0.3, -0.3, -kHalf - 0.02),
                                                        Vector3d(0.3, 0.3, -kHalf + 0.01), 1, "cut"), kDist));
  EXPECT_FALSE(SupportPlane::under(box, Mesh{}, kDist));
}

TEST(FreeSurface, SupportBoxLiesUnderThePlaneAndCoversTheFootprint) {
  const Mesh box = coarse_box();
  const SupportPlane plane = SupportPlane::below(box);
  const Mesh table = support_box(plane, box, 0.1);
  EXPECT_EQ(table.faces.rows(), 12);
  expect_closed(table);
  EXPECT_GT(volume(table), 0.0);  // outward
  EXPECT_NEAR(table.vertices.col(2).maxCoeff(), -kHalf, 1e-12);
  EXPECT_NEAR(table.vertices.col(2).minCoeff(), -kHalf - 0.1, 1e-12);
  EXPECT_NEAR(table.vertices.col(0).maxCoeff(), kHalf + 0.1, 1e-12);
  EXPECT_NEAR(table.vertices.col(1).minCoeff(), -kHalf - 0.1, 1e-12);
}

}  // namespace

// Graspable faces (graspable.hpp): a box far larger than the hand's span has none (at a corner the
// three inward normals lie arccos(1/sqrt(3)) = 54.7 degrees from the diagonal, inside the 63.4 degrees
// of mu = 0.5), one whose opposite faces lie within the span keeps them all, and the planner refuses the
// large box before building anything, naming mu.
namespace {

TEST(Graspable, ABoxFarLargerThanTheSpanHasNoGraspableFace) {
  const Mesh big = tmesh::box_mesh(Vector3d(-0.75, -0.4, -0.4), Vector3d(0.75, 0.4, 0.4), 1, "big");
  const GraspableFaces none = graspable_faces(big, Mask(), 0.27, 0.5);
  EXPECT_EQ(none.free, 12u);
  EXPECT_EQ(none.graspable, 0u);
  EXPECT_GE(none.widest_cone, std::acos(1.0 / std::sqrt(3.0)));
  EXPECT_EQ(graspable_faces(big, Mask(), 1.0, 0.5).graspable, 12u);  // 0.8 m apart: within a 1 m span
  EXPECT_EQ(graspable_faces(big, Mask(), 0.27, 1.0).graspable, 12u);  // mu = 1: cones of 45 degrees
  const Mesh small = tmesh::box_mesh(Vector3d::Constant(-kHalf), Vector3d::Constant(kHalf), 3);
  EXPECT_EQ(graspable_faces(small, Mask(), 0.27, 0.5).graspable, std::size_t(small.faces.rows()));
  EXPECT_THROW(graspable_faces(small, Mask(), 0.0, 0.5), std::invalid_argument);
  EXPECT_THROW(graspable_faces(small, Mask(), 0.2, -1.0), std::invalid_argument);
  EXPECT_THROW(graspable_faces(small, Mask::Constant(3, true), 0.2, 0.5), std::invalid_argument);
}

TEST(Graspable, ThePlannerRefusesATargetWithNothingGraspable) {
  const Hand hand = pairgrasp::testing_hands::barrett();
  const Mesh big = tmesh::box_mesh(Vector3d(-0.75, -0.4, -0.4), Vector3d(0.75, 0.4, 0.4), 1, "big");
  try {
    resolve_planner(hand, big, Mask(), PlannerOptions());
    FAIL() << "no refusal";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("force-closure"), std::string::npos) << what;
    EXPECT_NE(what.find("mu = 0.5"), std::string::npos) << what;
  }
  const PlannerSetup s = resolve_planner(hand, tmesh::box_mesh(Vector3d::Constant(-kHalf), Vector3d::Constant(kHalf)),
                                         Mask(), PlannerOptions());
  EXPECT_EQ(s.graspable_faces, 12u);
  EXPECT_GT(s.contact_span, pairgrasp::hand_span(hand));
}

}  // namespace
