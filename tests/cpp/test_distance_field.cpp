// DistanceField against the exact signed distance of SurfaceQuery (an independent, tree-based
// search): stored nodes equal it, and at random points near and far the exact value lies within
// the reported bounds, which in the band are no wider than the documented (√3/2)·h.
#include <pairgrasp/distance_field.hpp>
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/surface_query.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "test_meshes.hpp"

using namespace pairgrasp;
using Eigen::Vector3d;

namespace {

std::string target_path(const std::string& name) {
  return std::string(PAIRGRASP_MODEL_DIR) + "/targets/" + name + ".stl";
}

// Random points: half near the surface (a surface point moved along a random direction by up
// to 4 mm), half anywhere in the box grown by 2 cm.
std::vector<Vector3d> random_points(const Mesh& m, int n, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g;
  std::uniform_int_distribution<Eigen::Index> face(0, m.faces.rows() - 1);
  Eigen::AlignedBox3d box;
  for (Eigen::Index v = 0; v < m.vertices.rows(); ++v) box.extend(Vector3d(m.vertices.row(v).transpose()));
  std::vector<Vector3d> out;
  for (int i = 0; i < n; ++i) {
    if (i % 2 == 0) {
      const Eigen::Index f = face(rng);
      double a = u(rng), b = u(rng);
      if (a + b > 1.0) a = 1.0 - a, b = 1.0 - b;
      const Vector3d p0 = m.vertices.row(m.faces(f, 0)).transpose(), p1 = m.vertices.row(m.faces(f, 1)).transpose(),
                     p2 = m.vertices.row(m.faces(f, 2)).transpose();
      out.push_back(p0 + a * (p1 - p0) + b * (p2 - p0) + 0.004 * u(rng) * Vector3d(g(rng), g(rng), g(rng)).normalized());
    } else {
      out.push_back(box.min() - Vector3d::Constant(0.02) +
                    (box.sizes() + Vector3d::Constant(0.04)).cwiseProduct(Vector3d(u(rng), u(rng), u(rng))));
    }
  }
  return out;
}

void check_field(const Mesh& mesh, const DistanceFieldOptions& options, int points) {
  const SurfaceQuery q(mesh);
  const DistanceField f(q, options);
  std::printf("%s: %d of %d bricks, %.2f MB, built in %.3f s\n", mesh.source.c_str(), f.stored_bricks(),
              f.total_bricks(), f.nbytes() / 1e6, f.build_seconds());
  EXPECT_EQ(f.is_signed(), q.closed());
  EXPECT_LE(f.max_error(), 0.5 * std::sqrt(3.0) * options.cell + 1e-7);
  EXPECT_GT(f.stored_bricks(), 0);
  EXPECT_LT(f.stored_bricks(), f.total_bricks());
  auto exact = [&](const Vector3d& p) { return q.closed() ? q.signed_distance(p) : q.distance(p); };

  // Every stored node holds the exact value (to float rounding); a node grid stride keeps it quick.
  const Eigen::Vector3i nn = f.node_counts();
  int nodes = 0;
  for (int k = 0; k < nn.z(); k += 3)
    for (int j = 0; j < nn.y(); j += 2)
      for (int i = 0; i < nn.x(); ++i) {
        const auto v = f.node_value({i, j, k});
        if (!v) continue;
        ++nodes;
        const double e = exact(f.node_position({i, j, k}));
        ASSERT_NEAR(*v, e, 1e-7 * (1.0 + std::abs(e))) << i << " " << j << " " << k;
        // Stored nodes are those of bricks reaching into the band.
        ASSERT_LE(std::abs(e), f.band() + 4 * std::sqrt(3.0) * f.cell() + 1e-9);
      }
  EXPECT_GT(nodes, 100);

  std::mt19937_64 rng(7);
  int in_band = 0;
  for (const Vector3d& p : random_points(mesh, points, rng)) {
    const FieldSample s = f.sample(p);
    const double e = exact(p);
    ASSERT_LE(s.lower, e) << p.transpose();
    ASSERT_GE(s.upper, e) << p.transpose();
    if (s.in_band) {
      ++in_band;
      ASSERT_LE(s.upper - s.value, f.max_error());
      ASSERT_LE(std::abs(s.value - e), f.max_error());
    }
    // Every point within the band of the surface is interpolated.
    if (std::abs(e) <= f.band()) ASSERT_TRUE(s.in_band) << p.transpose() << " at " << e;
  }
  EXPECT_GT(in_band, points / 4);
}

}  // namespace

TEST(DistanceField, BundledTargetsHoldExactNodesAndTheBound) {
  for (const char* name : {"box", "mug", "flask"}) {
    SCOPED_TRACE(name);
    const Mesh m = load_mesh(target_path(name));
    check_field(m, {}, 20000);
  }
}

TEST(DistanceField, CoarseCellAndUnsignedOpenMesh) {
  const Mesh m = load_mesh(target_path("mug"));
  DistanceFieldOptions o;
  o.cell = 0.0025;
  o.band = 0.003;
  check_field(m, o, 10000);
  // The first half of the faces: an open surface, so the field is unsigned.
  std::vector<int> half;
  for (Eigen::Index i = 0; i < m.faces.rows() / 2; ++i) half.push_back(static_cast<int>(i));
  Mesh open = m;
  open.faces = m.faces.topRows(m.faces.rows() / 2);
  open.closed = false;
  check_field(open, {}, 10000);
}

TEST(DistanceField, ExactOnAPlaneFaceAndBoundedFarAway) {
  const Mesh cube = testing_meshes::box_mesh(Vector3d::Constant(-0.05), Vector3d::Constant(0.05), 4, "cube");
  const SurfaceQuery q(cube);
  const DistanceField f(q);
  // Near the middle of a face the distance is linear, which trilinear interpolation reproduces.
  const FieldSample s = f.sample({0.01234, -0.00321, 0.0513});
  EXPECT_TRUE(s.in_band);
  EXPECT_NEAR(s.value, 0.0013, 1e-6);
  // Deep inside (beyond the band): bounded by the brick centre, known inside.
  const FieldSample d = f.sample({0.001, 0.002, 0.003});
  EXPECT_FALSE(d.in_band);
  EXPECT_LT(d.upper, -f.band());
  // Deep under the middle of the top face (15..35 mm down, nearer to it than to any other face):
  // the bound by the brick centre's closest surface point, on the same face, leaves the depth
  // no more than sqrt(15^2 + 2.83^2) - 15 = 0.27 mm over the exact one (2.83 mm: a 4 mm brick's
  // half diagonal across the face), where the centre's distance alone left up to 6.9 mm.
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 200; ++i) {
    const Vector3d p(-0.01 + 0.02 * u(rng), -0.01 + 0.02 * u(rng), 0.015 + 0.02 * u(rng));
    const FieldSample s = f.sample(p);
    const double exact = p.z() - 0.05;
    ASSERT_FALSE(s.in_band);
    ASSERT_LE(s.lower, exact);
    ASSERT_GE(s.upper, exact);
    ASSERT_LE(-s.lower, -exact + 0.00027) << p.transpose();
  }
  // Beyond the grid: at least the distance to the box.
  const FieldSample far = f.sample({0.5, 0.0, 0.0});
  EXPECT_NEAR(far.lower, 0.45, 1e-12);
  EXPECT_TRUE(std::isinf(far.upper));
  EXPECT_THROW(DistanceField(q, DistanceFieldOptions{0.0}), std::invalid_argument);
}

TEST(DistanceField, SameNodesForAnyThreadCount) {
  const Mesh m = load_mesh(target_path("mug"));
  const SurfaceQuery q(m);
  DistanceFieldOptions a, b;
  a.threads = 1;
  b.threads = 2;
  const DistanceField fa(q, a), fb(q, b);
  ASSERT_EQ(fa.stored_bricks(), fb.stored_bricks());
  const Eigen::Vector3i nn = fa.node_counts();
  for (int k = 0; k < nn.z(); k += 5)
    for (int j = 0; j < nn.y(); ++j)
      for (int i = 0; i < nn.x(); ++i) ASSERT_EQ(fa.node_value({i, j, k}), fb.node_value({i, j, k}));
}
