// Unit facets: even areas, area preserved, normals and paint from the source faces, bad input.
#include <gtest/gtest.h>
#include <pairgrasp/facets.hpp>
#include <pairgrasp/paint.hpp>

#include "surface_test_meshes.hpp"

#include <cmath>
#include <map>
#include <regex>
#include <string>

using namespace pairgrasp;
using namespace surface_test;

namespace {

// Checks every facet against its source face, computed here from the mesh arrays.
void expect_consistent(const Mesh& m, const UnitFacets& u, const Mask& paint = Mask()) {
  const long n = u.points.rows();
  ASSERT_GT(n, 0);
  ASSERT_EQ(u.normals.rows(), n);
  ASSERT_EQ(u.areas.size(), n);
  ASSERT_EQ(u.face_ids.size(), n);
  ASSERT_EQ(u.free.size(), n);
  for (long i = 0; i < n; ++i) {
    const int f = u.face_ids[i];
    ASSERT_GE(f, 0);
    ASSERT_LT(f, m.faces.rows());
    const Eigen::Vector3d nf = face_normal(m, f);
    EXPECT_NEAR(u.normals.row(i).norm(), 1.0, 1e-12);
    EXPECT_LT((u.normals.row(i).transpose() - nf).norm(), 1e-12) << "facet " << i;
    // The centre lies in the source triangle: barycentric coordinates in [0, 1], on its plane.
    const Eigen::Vector3d a = m.vertices.row(m.faces(f, 0)).transpose();
    const Eigen::Vector3d b = m.vertices.row(m.faces(f, 1)).transpose();
    const Eigen::Vector3d c = m.vertices.row(m.faces(f, 2)).transpose();
    const Eigen::Vector3d p = u.points.row(i).transpose();
    EXPECT_NEAR(nf.dot(p - a), 0.0, 1e-12);
    const double area2 = (b - a).cross(c - a).norm();
    const double wa = (c - b).cross(p - b).dot(nf) / area2, wb = (a - c).cross(p - c).dot(nf) / area2;
    EXPECT_GE(wa, -1e-9);
    EXPECT_GE(wb, -1e-9);
    EXPECT_GE(1.0 - wa - wb, -1e-9);
    EXPECT_GT(u.areas[i], 0.0);
    EXPECT_EQ(u.free[i], paint.size() ? paint[f] : true);
  }
  EXPECT_NEAR(u.areas.sum(), mesh_area(m), 1e-9 * mesh_area(m));
}

// Total facet area per distinct normal direction (facets never span a sharp edge).
std::map<std::tuple<long, long, long>, double> area_by_normal(const Points& normals, const Eigen::VectorXd& areas) {
  std::map<std::tuple<long, long, long>, double> out;
  for (long i = 0; i < normals.rows(); ++i)
    out[{std::lround(normals(i, 0) * 1000), std::lround(normals(i, 1) * 1000), std::lround(normals(i, 2) * 1000)}] +=
        areas[i];
  return out;
}

}  // namespace

TEST(Facets, BoxEvenAreasAndSidesKeptApart) {
  const Mesh m = box(0.1, 0.06, 0.04);
  const double h = 0.01;
  const UnitFacets u = tessellate(m, h);
  expect_consistent(m, u);
  EXPECT_DOUBLE_EQ(u.edge, h);
  EXPECT_LE(cv(u.areas), 0.3);
  // Each side keeps exactly its own area: 2 (ab + bc + ca), side by side.
  auto by = area_by_normal(u.normals, u.areas);
  ASSERT_EQ(by.size(), 6u);
  EXPECT_NEAR((by[{1000, 0, 0}]), 0.06 * 0.04, 1e-12);
  EXPECT_NEAR((by[{0, -1000, 0}]), 0.1 * 0.04, 1e-12);
  EXPECT_NEAR((by[{0, 0, 1000}]), 0.1 * 0.06, 1e-12);
  // About A / ((sqrt(3)/2) h^2) facets.
  const double expected = 2 * (0.1 * 0.06 + 0.06 * 0.04 + 0.1 * 0.04) / (std::sqrt(3.0) / 2 * h * h);
  EXPECT_NEAR(double(u.points.rows()), expected, 0.25 * expected);
}

TEST(Facets, FlatSquareDensityMatchesEdge) {
  Mesh m = box(0.2, 0.2, 0.2);
  m.faces.conservativeResize(2, 3);  // the bottom square alone (an open mesh; only faces are read)
  const double h = 0.005;
  const UnitFacets u = tessellate(m, h);
  expect_consistent(m, u);
  const double expected = 0.04 / (std::sqrt(3.0) / 2 * h * h);
  EXPECT_NEAR(double(u.points.rows()), expected, 0.15 * expected);
  EXPECT_LE(cv(u.areas), 0.2);
  // Facet centres are spread about h apart: every point of the square is near a centre.
  for (double x = 0.0025; x < 0.2; x += 0.01)
    for (double y = 0.0025; y < 0.2; y += 0.01) {
      const double d = (u.points.rowwise() - Eigen::RowVector3d(x, y, 0)).rowwise().norm().minCoeff();
      EXPECT_LT(d, 0.75 * h);
    }
}

TEST(Facets, CylinderWithFanCaps) {
  const int seg = 96;
  const double r = 0.03, H = 0.1, h = 0.005;
  const Mesh m = fan_cylinder(r, H, seg);
  // The caps are fans of slivers (15:1 edges), the side long strips (50:1).
  const double cap_edge = 2 * r * std::sin(M_PI / seg);
  ASSERT_GT(r / cap_edge, 15.0);
  const UnitFacets u = tessellate(m, h);
  expect_consistent(m, u);
  EXPECT_LE(cv(u.areas), 0.3);
  // Analytic area of the polygonal cylinder.
  const double side = seg * 2 * r * std::sin(M_PI / seg) * H, cap = 0.5 * seg * r * r * std::sin(2 * M_PI / seg);
  EXPECT_NEAR(u.areas.sum(), side + 2 * cap, 1e-9 * (side + 2 * cap));
  auto by = area_by_normal(u.normals, u.areas);
  EXPECT_NEAR((by[{0, 0, 1000}]), cap, 1e-12);
  EXPECT_NEAR((by[{0, 0, -1000}]), cap, 1e-12);
}

TEST(Facets, IcosphereFineAndCoarse) {
  for (int level : {0, 1, 4}) {
    const Mesh m = icosphere(0.05, level);
    for (double h : {0.004, 0.01}) {
      const UnitFacets u = tessellate(m, h);
      expect_consistent(m, u);
      EXPECT_LE(cv(u.areas), 0.3) << "level " << level << " h " << h;
    }
  }
}

TEST(Facets, PaintInheritedAndNeverMixed) {
  const Mesh m = fan_cylinder(0.03, 0.08, 48);
  Mask paint(m.faces.rows());
  double free_area = 0.0;
  for (int f = 0; f < m.faces.rows(); ++f) {
    // free: faces whose centroid is above z = 0.05 and at x > 0 (cuts across the side).
    const Eigen::Vector3d c =
        (m.vertices.row(m.faces(f, 0)) + m.vertices.row(m.faces(f, 1)) + m.vertices.row(m.faces(f, 2))) / 3.0;
    paint[f] = c.z() > 0.03 && c.x() > 0.0;
    if (paint[f]) free_area += face_area(m, f);
  }
  ASSERT_GT(free_area, 0.0);
  const UnitFacets u = tessellate(m, 0.006, paint);
  expect_consistent(m, u, paint);
  double got = 0.0;
  for (long i = 0; i < u.areas.size(); ++i)
    if (u.free[i]) got += u.areas[i];
  // A facet is painted as a whole: free facets cover exactly the free faces.
  EXPECT_NEAR(got, free_area, 1e-12);
}

TEST(Facets, ThinWallKeepsSidesApart) {
  // Two opposite-facing squares 1 mm apart (a thin wall, h = 5 mm).
  std::vector<Eigen::Vector3d> v = {{0, 0, 0}, {0.05, 0, 0}, {0.05, 0.05, 0}, {0, 0.05, 0},
                                    {0, 0, 0.001}, {0.05, 0, 0.001}, {0.05, 0.05, 0.001}, {0, 0.05, 0.001}};
  std::vector<Eigen::Vector3i> f = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}};
  const Mesh m = from_arrays(v, f, "wall");
  const UnitFacets u = tessellate(m, 0.005);
  expect_consistent(m, u);
  auto by = area_by_normal(u.normals, u.areas);
  ASSERT_EQ(by.size(), 2u);
  EXPECT_NEAR((by[{0, 0, 1000}]), 0.0025, 1e-12);
  EXPECT_NEAR((by[{0, 0, -1000}]), 0.0025, 1e-12);
  EXPECT_LE(cv(u.areas), 0.3);
}

TEST(Facets, SmallFacesAreRepresented) {
  // A box plus a detached triangle much smaller than h: it must get a facet of its own area.
  Mesh m = box(0.05, 0.05, 0.05);
  const long V = m.vertices.rows(), F = m.faces.rows();
  m.vertices.conservativeResize(V + 3, 3);
  m.vertices.row(V) << 0.2, 0.2, 0.2;
  m.vertices.row(V + 1) << 0.2005, 0.2, 0.2;
  m.vertices.row(V + 2) << 0.2, 0.2005, 0.2;
  m.faces.conservativeResize(F + 1, 3);
  m.faces.row(F) << int(V), int(V + 1), int(V + 2);
  const UnitFacets u = tessellate(m, 0.01);
  expect_consistent(m, u);
  int hits = 0;
  for (long i = 0; i < u.face_ids.size(); ++i)
    if (u.face_ids[i] == F) {
      ++hits;
      EXPECT_NEAR(u.areas[i], 0.5 * 0.0005 * 0.0005, 1e-15);
    }
  EXPECT_EQ(hits, 1);
}

TEST(Facets, Deterministic) {
  const Mesh m = icosphere(0.04, 2);
  const UnitFacets a = tessellate(m, 0.006), b = tessellate(m, 0.006);
  ASSERT_EQ(a.points.rows(), b.points.rows());
  EXPECT_EQ(a.points, b.points);
  EXPECT_EQ(a.areas, b.areas);
  EXPECT_EQ(a.face_ids, b.face_ids);
}

TEST(Facets, BadInput) {
  const Mesh m = box(0.1, 0.1, 0.1);
  for (double e : {0.0, -0.01, std::nan(""), double(INFINITY)})
    EXPECT_THROW(tessellate(m, e), std::invalid_argument) << e;
  EXPECT_THROW(tessellate(m, 0.01, Mask::Constant(5, true)), std::invalid_argument);
  try {
    tessellate(m, 0.01, Mask::Constant(5, true));
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("free_faces: expected 12, got 5"), std::string::npos) << e.what();
  }
  EXPECT_THROW(tessellate(Mesh(), 0.01), std::invalid_argument);
  Mesh nan = m;
  nan.vertices(3, 1) = std::nan("");
  EXPECT_THROW(tessellate(nan, 0.01), std::invalid_argument);
  Mesh out_of_range = m;
  out_of_range.faces(2, 2) = 8;
  EXPECT_THROW(tessellate(out_of_range, 0.01), std::invalid_argument);
  EXPECT_THROW(tessellate(m, 0.01, Mask(), 0), std::invalid_argument);
}

TEST(Facets, FacetLimitNamesAnEdgeThatFits) {
  const Mesh m = icosphere(0.07, 3);
  const long limit = 500;
  std::string msg;
  try {
    tessellate(m, 0.001, Mask(), limit);  // about 71,000 facets
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    msg = e.what();
  }
  std::smatch match;
  ASSERT_TRUE(std::regex_search(msg, match, std::regex("smallest edge that fits is about ([0-9.eE+-]+) m"))) << msg;
  const double fit = std::stod(match[1]);
  EXPECT_GT(fit, 0.001);
  const UnitFacets u = tessellate(m, fit, Mask(), limit);
  EXPECT_LE(u.points.rows(), limit);
  EXPECT_GT(u.points.rows(), limit * 0.8);  // and it is about the smallest
}

TEST(Facets, BundledTargetsWithTheirPaint) {
  for (const char* name : {"box", "mug", "flask"}) {
    const std::string base = std::string(PAIRGRASP_MODEL_DIR) + "/targets/" + name;
    const Mesh m = load_mesh(base + ".stl");
    const Mask paint = load_paint(base + ".paint.json", m);
    const double extent = (m.vertices.colwise().maxCoeff() - m.vertices.colwise().minCoeff()).maxCoeff();
    for (double div : {25.0, 40.0}) {
      const UnitFacets u = tessellate(m, extent / div, paint);
      expect_consistent(m, u, paint);
      EXPECT_LE(cv(u.areas), 0.3) << name << " edge " << extent / div;
      double free_area = 0.0, got = 0.0;
      for (long f = 0; f < m.faces.rows(); ++f)
        if (paint[f]) free_area += face_area(m, int(f));
      for (long i = 0; i < u.areas.size(); ++i)
        if (u.free[i]) got += u.areas[i];
      EXPECT_NEAR(got, free_area, 1e-9 * free_area) << name;
    }
  }
}
