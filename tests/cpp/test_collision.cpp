// GraspChecker against geometry whose penetration is known exactly from the dimensions: a
// 20 mm probe cube and the bundled parallel jaw against a 0.1 m cube, a table and occluded faces.
#include <pairgrasp/collision.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

#include "test_hands.hpp"
#include "test_meshes.hpp"

using namespace pairgrasp;
using Eigen::Vector3d;
namespace tmesh = pairgrasp::testing_meshes;
namespace th = pairgrasp::testing_hands;

namespace {

const double kPi = 3.14159265358979323846;

// The 0.1 m cube [-0.05, 0.05]^3, faces in 2.5 cm squares.
Mesh cube() { return tmesh::box_mesh(Vector3d::Constant(-0.05), Vector3d::Constant(0.05), 4, "cube"); }

Eigen::VectorXd dofs1(double v) { return Eigen::VectorXd::Constant(1, v); }

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

class ProbeVsCube : public ::testing::Test {
 protected:
  th::TempDir dir;
  Hand hand = th::probe_hand(dir);
  Mesh target = cube();
};

TEST_F(ProbeVsCube, PushedFiveMillimetresInIsPrunedWithThatDepth) {
  const GraspChecker checker(hand, target);  // tolerance 1.25 mm, gap 1 mm
  // Probe z in [-0.065, -0.045] under the cube's bottom face z = -0.05: 5 mm inside.
  const CheckResult r = checker.check(th::pose(Vector3d(0, 0, -0.065)), dofs1(0.0));
  ASSERT_EQ(r.links.size(), 1u);
  EXPECT_TRUE(r.collision);
  EXPECT_TRUE(r.links[0].colliding);
  // Every sample of the probe's top face (and the cube's bottom face inside the probe) is
  // 5 mm from the other surface; nothing is deeper.
  EXPECT_NEAR(r.depth, 0.005, 1e-9);
  EXPECT_NEAR(r.target_depth, 0.005, 1e-9);
  EXPECT_TRUE(r.penetrating);
  EXPECT_TRUE(r.pruned);
  EXPECT_TRUE(contains(r.reason, "penetration 5.00 mm > tolerance 1.25 mm")) << r.reason;
  ASSERT_EQ(r.pairs.size(), 1u);
  EXPECT_EQ(r.pairs[0].link, "probe");
  EXPECT_EQ(r.pairs[0].other, "target");
  EXPECT_TRUE(r.pairs[0].intersecting);
  EXPECT_FALSE(r.pairs[0].obstacle);
  // Sliding the probe up by the DOF instead of the wrist gives the same 5 mm (FK in the loop).
  const CheckResult r2 = checker.check(th::pose(Vector3d(0, 0, -0.075)), dofs1(0.01));
  EXPECT_NEAR(r2.depth, 0.005, 1e-9);
  // 1 mm in: collides but within the 1.25 mm tolerance, so kept.
  const CheckResult r3 = checker.check(th::pose(Vector3d(0, 0, -0.069)), dofs1(0.0));
  EXPECT_TRUE(r3.collision);
  EXPECT_NEAR(r3.depth, 0.001, 1e-9);
  EXPECT_FALSE(r3.pruned);
  EXPECT_TRUE(r3.reason.empty());
}

TEST_F(ProbeVsCube, JustTouchingIsKept) {
  const GraspChecker checker(hand, target);
  // 0.1 mm below the bottom face.
  const CheckResult r = checker.check(th::pose(Vector3d(0, 0, -0.0701)), dofs1(0.0));
  EXPECT_FALSE(r.collision);
  EXPECT_EQ(r.depth, 0.0);
  EXPECT_FALSE(r.pruned);
  EXPECT_TRUE(r.pairs.empty());
  EXPECT_TRUE(r.reason.empty());
}

TEST_F(ProbeVsCube, LinkWhollyInsideIsPrunedThoughFclSeesNoIntersection) {
  const GraspChecker checker(hand, target);
  // Probe z in [-0.01, 0.01]: wholly inside the cube, no triangle crosses another.
  const CheckResult r = checker.check(th::pose(Vector3d(0, 0, -0.01)), dofs1(0.0));
  ASSERT_EQ(r.pairs.size(), 1u);
  // FCL's triangle test alone reports nothing here: that is why the inside test exists.
  EXPECT_FALSE(r.pairs[0].intersecting);
  EXPECT_TRUE(r.pairs[0].inside);
  EXPECT_TRUE(r.collision);
  // Every point of the probe's surface has max(|x|,|y|,|z|) = 0.01: 0.04 m from the cube's faces.
  EXPECT_NEAR(r.depth, 0.04, 1e-9);
  EXPECT_TRUE(r.pruned);
}

TEST_F(ProbeVsCube, CornerPokingIntoAFlatFaceIsMeasuredFromTheTargetSide) {
  const GraspChecker checker(hand, target);
  // Turn the probe so that its top face (normal +z of the link) faces the cube's corner
  // (0.05, 0.05, 0.05) along (-1,-1,-1)/sqrt(3), its face centre on that diagonal, and push the
  // corner 3 mm into it. The probe's own samples inside the cube are shallow (the cube's corner is
  // a thin tetrahedron there), but the corner itself is 3 mm deep in the probe.
  const Vector3d corner(0.05, 0.05, 0.05);
  const Vector3d n = Vector3d(1, 1, 1).normalized();  // probe face normal must be -n
  Pose w = Pose::Identity();
  w.linear() = Eigen::Quaterniond::FromTwoVectors(Vector3d::UnitZ(), -n).toRotationMatrix();
  // Link top face centre is at link (0, 0, 0.02); place it 3 mm inside along -n from the corner.
  w.translation() = corner - 0.003 * n - w.linear() * Vector3d(0, 0, 0.02);
  const CheckResult r = checker.check(w, dofs1(0.0));
  EXPECT_TRUE(r.collision);
  EXPECT_NEAR(r.depth, 0.003, 1e-9);
  EXPECT_TRUE(r.pruned);
}

TEST_F(ProbeVsCube, TouchingOccludedFacesPrunes) {
  Mask free = Mask::Constant(target.faces.rows(), true);
  for (int f = 0; f < target.faces.rows(); ++f)
    if (target.face_normal(f).z() < -0.5) free[f] = false;  // the bottom rests on something
  const GraspChecker checker(hand, target, free);
  // 0.5 mm under the (occluded) bottom: within the 1 mm gap, no collision.
  const CheckResult below = checker.check(th::pose(Vector3d(0, 0, -0.0705)), dofs1(0.0));
  EXPECT_FALSE(below.collision);
  EXPECT_TRUE(below.touches_occluded);
  EXPECT_TRUE(below.links[0].touches_occluded);
  EXPECT_TRUE(below.pruned);
  EXPECT_TRUE(contains(below.reason, "touches occluded target faces (probe)")) << below.reason;
  // 2 mm under it: beyond the gap, kept.
  EXPECT_FALSE(checker.check(th::pose(Vector3d(0, 0, -0.072)), dofs1(0.0)).pruned);
  // 0.5 mm above the (free) top face, probe turned over: kept.
  const CheckResult above = checker.check(th::pose(Vector3d(0, 0, 0.0705), kPi), dofs1(0.0));
  EXPECT_FALSE(above.touches_occluded);
  EXPECT_FALSE(above.pruned);
  // Beside the cube, level with the bottom edge, 0.5 mm from the side (free) face but 0.5 mm
  // from the occluded bottom's edge too: pruned.
  const CheckResult edge = checker.check(th::pose(Vector3d(0.0605, 0, -0.0695)), dofs1(0.0));
  EXPECT_TRUE(edge.touches_occluded);
}

TEST_F(ProbeVsCube, ObstaclesPruneOnIntersection) {
  // A table under the cube (closed slab) and a wall given as an open quad.
  const Mesh table = tmesh::box_mesh(Vector3d(-0.3, -0.3, -0.07), Vector3d(0.3, 0.3, -0.05), 1, "table");
  Points V(4, 3);
  V << 0.1, -0.2, -0.2, 0.1, 0.2, -0.2, 0.1, 0.2, 0.2, 0.1, -0.2, 0.2;
  Triangles F(2, 3);
  F << 0, 1, 2, 0, 2, 3;
  const Mesh wall = make_mesh(V, F, "wall");
  const GraspChecker checker(hand, target, Mask(), {{"table", table}, {"wall", wall}});
  // Beside the cube, probe z in [-0.055, -0.035]: 5 mm into the table's top (z = -0.05).
  const CheckResult r = checker.check(th::pose(Vector3d(0.075, 0, -0.055)), dofs1(0.0));
  EXPECT_TRUE(r.obstacle_collision);
  EXPECT_TRUE(r.pruned);
  EXPECT_FALSE(r.penetrating);
  ASSERT_EQ(r.pairs.size(), 1u);
  EXPECT_EQ(r.pairs[0].other, "table");
  EXPECT_TRUE(r.pairs[0].obstacle);
  EXPECT_NEAR(r.pairs[0].depth, 0.005, 1e-9);
  EXPECT_TRUE(contains(r.reason, "obstacle collision (probe with table)")) << r.reason;
  // Wholly inside the table (which FCL cannot see): still an obstacle collision.
  const Mesh thick = tmesh::box_mesh(Vector3d(-0.3, -0.3, -0.2), Vector3d(0.3, 0.3, -0.05), 1, "thick table");
  const GraspChecker checker2(hand, target, Mask(), {{"table", thick}});
  const CheckResult r2 = checker2.check(th::pose(Vector3d(0.0, 0, -0.15)), dofs1(0.0));
  EXPECT_TRUE(r2.obstacle_collision);
  EXPECT_FALSE(r2.pairs.at(0).intersecting);
  // The open wall x = 0.1 crossed by the probe: reported (no depth for an open mesh).
  const CheckResult r3 = checker.check(th::pose(Vector3d(0.1, 0, 0.0)), dofs1(0.0));
  ASSERT_EQ(r3.pairs.size(), 1u);
  EXPECT_EQ(r3.pairs[0].other, "wall");
  EXPECT_TRUE(r3.pairs[0].intersecting);
  EXPECT_TRUE(r3.pruned);
  // Clear of everything: kept.
  EXPECT_FALSE(checker.check(th::pose(Vector3d(0.075, 0, -0.045)), dofs1(0.0)).pruned);
}

TEST(Collision, ParallelJawOnTheCube) {
  const Hand jaw = th::parallel_jaw();
  const Mesh target = cube();
  const GraspChecker checker(jaw, target);
  // The jaw's fingers occupy wrist z in [0.05, 0.12], pads at x = -+opening/2 facing inwards.
  // Wrist at z = -0.101 puts the fingers over z in [-0.051, 0.019] of the cube's sides.
  const Pose w = th::pose(Vector3d(0, 0, -0.101));  // base 1 mm under the cube
  EXPECT_THROW(checker.check(w, dofs1(0.102)), std::invalid_argument);
  // Opening 0.08 < 0.1: each pad is 10 mm inside the cube's side face.
  const CheckResult r = checker.check(w, dofs1(0.08));
  EXPECT_NEAR(r.depth, 0.01, 1e-9);
  EXPECT_TRUE(r.pruned);
  EXPECT_EQ(r.pairs.size(), 2u);  // both fingers
  // Move the wrist down so the fingers clear the cube: the fingertips (z = 0.12) 0.1 mm under it.
  const CheckResult clear = checker.check(th::pose(Vector3d(0, 0, -0.1701)), dofs1(0.0));
  EXPECT_FALSE(clear.collision);
  EXPECT_FALSE(clear.pruned);
}

TEST(Collision, CheckManyEqualsSerialCheck) {
  const Hand hand = th::barrett();
  const Mesh target = tmesh::icosphere(0.04, 2, Vector3d(0, 0, 0.13));
  const GraspChecker checker(hand, target);
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Pose> wrists;
  std::vector<Eigen::VectorXd> dofs;
  for (int k = 0; k < 24; ++k) {
    wrists.push_back(th::pose(0.08 * Vector3d(u(rng), u(rng), u(rng)), 0.3 * u(rng),
                              Vector3d(u(rng), u(rng), u(rng))));
    Eigen::VectorXd q(4);
    q << 1.5 * (1 + u(rng)), 1.2 * (1 + u(rng)), 1.2 * (1 + u(rng)), 1.2 * (1 + u(rng));
    dofs.push_back(q);
  }
  const auto many = checker.check_many(wrists, dofs, 3);
  const auto one_thread = checker.check_many(wrists, dofs, 1);
  ASSERT_EQ(many.size(), 24u);
  int pruned = 0, kept = 0;
  for (int k = 0; k < 24; ++k) {
    const CheckResult s = checker.check(wrists[k], dofs[k]);
    for (const auto* m : {&many[k], &one_thread[k]}) {
      ASSERT_EQ(m->pruned, s.pruned);
      ASSERT_EQ(m->depth, s.depth);
      ASSERT_EQ(m->reason, s.reason);
      ASSERT_EQ(m->pairs.size(), s.pairs.size());
      for (size_t l = 0; l < s.links.size(); ++l) {
        ASSERT_EQ(m->links[l].colliding, s.links[l].colliding);
        ASSERT_EQ(m->links[l].depth, s.links[l].depth);
      }
    }
    pruned += s.pruned;
    kept += !s.pruned;
  }
  EXPECT_GT(pruned, 0);  // the sample set exercises both outcomes
  EXPECT_GT(kept, 0);
}

TEST_F(ProbeVsCube, InexactDepthStopsBeyondTheToleranceOnly) {
  const GraspChecker checker(hand, target);  // tolerance 1.25 mm
  // Wholly inside, 40 mm deep: still pruned, the depth a lower bound beyond the tolerance.
  const CheckResult deep = checker.check(th::pose(Vector3d(0, 0, -0.01)), dofs1(0.0), false);
  EXPECT_TRUE(deep.pruned && deep.penetrating);
  EXPECT_GT(deep.depth, 0.00125);
  EXPECT_LE(deep.depth, 0.04 + 1e-9);
  // 1 mm in, within the tolerance: exact.
  const CheckResult shallow = checker.check(th::pose(Vector3d(0, 0, -0.069)), dofs1(0.0), false);
  EXPECT_NEAR(shallow.depth, 0.001, 1e-9);
  EXPECT_FALSE(shallow.pruned);
}

TEST(Collision, InexactDepthKeepsEveryFlag) {
  const Hand hand = th::barrett();
  const Mesh target = tmesh::icosphere(0.04, 2, Vector3d(0, 0, 0.13));
  const GraspChecker checker(hand, target);
  const double tol = checker.options().depth_tolerance;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  int deep = 0;
  for (int k = 0; k < 40; ++k) {
    const Pose w = th::pose(0.08 * Vector3d(u(rng), u(rng), u(rng)), 0.3 * u(rng), Vector3d(u(rng), u(rng), u(rng)));
    Eigen::VectorXd q(4);
    q << 1.5 * (1 + u(rng)), 1.2 * (1 + u(rng)), 1.2 * (1 + u(rng)), 1.2 * (1 + u(rng));
    const CheckResult e = checker.check(w, q), f = checker.check(w, q, false);
    ASSERT_EQ(f.pruned, e.pruned);
    ASSERT_EQ(f.penetrating, e.penetrating);
    ASSERT_EQ(f.collision, e.collision);
    ASSERT_EQ(f.touches_occluded, e.touches_occluded);
    for (size_t l = 0; l < e.links.size(); ++l) {
      ASSERT_EQ(f.links[l].colliding, e.links[l].colliding);
      if (e.links[l].depth <= tol) {
        ASSERT_EQ(f.links[l].depth, e.links[l].depth);
      } else {
        ASSERT_GT(f.links[l].depth, tol);
        ASSERT_LE(f.links[l].depth, e.links[l].depth);
        ++deep;
      }
    }
  }
  EXPECT_GT(deep, 0);  // the poses exercise the early stop
}

TEST(Collision, BadInputThrows) {
  th::TempDir dir;
  const Hand hand = th::probe_hand(dir);
  const Mesh target = cube();
  auto expect_msg = [](auto&& fn, const std::string& start) {
    try {
      fn();
      FAIL() << "expected invalid_argument starting with " << start;
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind(start, 0), 0u) << e.what();
    }
  };
  expect_msg([&] { GraspChecker(hand, target, Mask::Constant(5, true)); }, "free: expected 192, got 5");
  expect_msg([&] { GraspChecker(hand, target, Mask::Constant(192, false)); }, "no free face left: ");
  CheckOptions bad;
  bad.depth_tolerance = -1;
  expect_msg([&] { GraspChecker(hand, target, Mask(), {}, bad); }, "depth_tolerance: ");
  bad = CheckOptions();
  bad.contact_gap = std::nan("");
  expect_msg([&] { GraspChecker(hand, target, Mask(), {}, bad); }, "contact_gap: ");
  bad = CheckOptions();
  bad.depth_tolerance = 0;
  expect_msg([&] { GraspChecker(hand, target, Mask(), {}, bad); }, "sample_spacing: ");
  expect_msg([&] { GraspChecker(hand, target, Mask(), {{"empty", Mesh{}}}); }, "obstacles[0]: ");

  const GraspChecker checker(hand, target);
  Pose scaled = Pose::Identity();
  scaled.linear() *= 1.1;
  expect_msg([&] { checker.check(scaled, dofs1(0)); }, "wrist: rotation is not orthonormal");
  Pose mirrored = Pose::Identity();
  mirrored.linear()(0, 0) = -1;
  expect_msg([&] { checker.check(mirrored, dofs1(0)); }, "wrist: rotation is a reflection");
  Pose nan_pose = Pose::Identity();
  nan_pose.translation().x() = std::nan("");
  expect_msg([&] { checker.check(nan_pose, dofs1(0)); }, "wrist: not finite");
  expect_msg([&] { checker.check(Pose::Identity(), Eigen::VectorXd::Zero(2)); }, "dofs: expected 1, got 2");
  expect_msg([&] { checker.check(Pose::Identity(), dofs1(std::nan(""))); }, "dofs[0]");
  expect_msg([&] { checker.check_many({Pose::Identity()}, {}); }, "dofs: expected 1 DOF vectors");
  expect_msg([&] { checker.check_many({Pose::Identity(), scaled}, {dofs1(0), dofs1(0)}); }, "wrists[1]: ");
}

TEST(Collision, SampleCountsFollowTheSpacing) {
  th::TempDir dir;
  const Hand hand = th::probe_hand(dir);
  for (double spacing : {0.0021, 0.001}) {
    CheckOptions opt;
    opt.sample_spacing = spacing;
    const GraspChecker checker(hand, cube(), Mask(), {}, opt);
    ASSERT_EQ(checker.link_sample_counts().size(), 1u);
    // The 20 mm cube has area 2400 mm^2: about area / spacing^2 lattice points inside the faces
    // plus the 18 edges (12 sides, 6 diagonals; 325 mm in all) at the spacing and 8 vertices.
    const double area = 6 * 0.02 * 0.02, edges = 12 * 0.02 + 6 * 0.02 * std::sqrt(2.0);
    const int n = checker.link_sample_counts()[0];
    EXPECT_GT(n, 0.5 * area / (spacing * spacing));
    EXPECT_LT(n, area / (spacing * spacing) + edges / spacing + 8 + 1);
    // The 0.1 m cube target likewise (area 0.06 m^2).
    const int t = checker.target_sample_count();
    EXPECT_GT(t, 0.5 * 0.06 / (spacing * spacing));
    EXPECT_LT(t, 0.06 / (spacing * spacing) + (12 * 0.1 + 6 * 0.1 * std::sqrt(2.0) + 24 * 0.025) / spacing * 4 + 200);
  }
}

TEST(Collision, SampleBudgetErrorNamesTheOption) {
  th::TempDir dir;
  const Hand hand = th::probe_hand(dir);
  CheckOptions opt;
  opt.sample_spacing = 1e-6;  // (0.1 m cube: 6e10 samples)
  try {
    GraspChecker(hand, cube(), Mask(), {}, opt);
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("sample_spacing: ", 0), 0u) << e.what();
    EXPECT_TRUE(contains(e.what(), "surface samples")) << e.what();
  }
}
