// The Aligner's antipodal alignment of a parallel jaw, against facts of a box moved by a known random
// rigid transform: its grasp lines close along the faces' normals, centred between the faces, only
// across widths the jaw spans, and every antipodal pair a brute-force scan finds votes.
#include <pairgrasp/aligner.hpp>
#include <pairgrasp/facets.hpp>
#include <pairgrasp/mesh.hpp>

#include "test_meshes.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>
#include <string>
#include <tuple>

using namespace pairgrasp;
using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

constexpr double kPi = 3.14159265358979323846;

struct MovedBox {
  Matrix3d R;
  Vector3d t;
  UnitFacets facets;
};

// A 4 x 6 x 10 cm box centred on the origin, moved by a random rigid transform, at h = 5 mm.
MovedBox moved_box(unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  Eigen::Quaterniond q(g(rng), g(rng), g(rng), g(rng));
  q.normalize();
  MovedBox b{q.toRotationMatrix(), Vector3d(g(rng), g(rng), g(rng)) * 0.1, {}};
  Mesh m = testing_meshes::box_mesh(Vector3d(-0.02, -0.03, -0.05), Vector3d(0.02, 0.03, 0.05), 1, "box");
  Points v = m.vertices;
  for (Eigen::Index i = 0; i < v.rows(); ++i) v.row(i) = (b.R * m.vertices.row(i).transpose() + b.t).transpose();
  b.facets = tessellate(make_mesh(v, m.faces, "moved box"), 0.005);
  return b;
}

// The jaw's pads w apart along the wrist's y axis, 10 cm out along z, facing each other.
std::pair<Points, Points> jaw(double w) {
  Points p(2, 3), n(2, 3);
  p << 0, -w / 2, 0.1, 0, w / 2, 0.1;
  n << 0, 1, 0, 0, -1, 0;
  return {p, n};
}

PairIndex indexed(const MovedBox& b) {
  PairIndexOptions io;
  io.d_max = 0.12;
  return PairIndex(b.facets.points, b.facets.normals, Mask(), io);
}

double angle_deg(const Vector3d& a, const Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / kPi;
}

}  // namespace

TEST(Antipodal, LinesCloseAlongTheFaceNormalsCentredBetweenTheFaces) {
  const MovedBox b = moved_box(11);
  const PairIndex index = indexed(b);
  AlignerOptions o;
  o.max_poses = 500;
  const Aligner aligner(index, o);
  const auto [p, n] = jaw(0.05);  // spans the 4 cm faces only
  const AlignResult r = aligner.align_antipodal(p, n);
  ASSERT_FALSE(r.poses.empty());
  ASSERT_EQ(r.poses.size() % 8, 0u);
  const Vector3d g(0, 1, 0), m_g(0, 0, 0.1);
  for (const AlignedPose& pose : r.poses) {
    // The closing axis is the box's x axis (either sign), the centre on the mid-plane x = 0 and
    // within the faces.
    const Vector3d axis = pose.rotation * g;
    EXPECT_LT(std::min(angle_deg(axis, b.R.col(0)), angle_deg(axis, -b.R.col(0))), 1e-6);
    const Vector3d c = b.R.transpose() * (pose.rotation * m_g + pose.translation - b.t);
    EXPECT_NEAR(c.x(), 0.0, 1e-9);
    EXPECT_LE(std::abs(c.y()), 0.03 + 1e-9);
    EXPECT_LE(std::abs(c.z()), 0.05 + 1e-9);
    EXPECT_NEAR(pose.rotation.determinant(), 1.0, 1e-12);
  }
  // Each line's poses turn about the line by 45 degrees from one to the next.
  for (std::size_t k = 0; k + 1 < 8; ++k) {
    const Matrix3d d = r.poses[k + 1].rotation * r.poses[k].rotation.transpose();
    EXPECT_NEAR(std::acos(std::clamp((d.trace() - 1) / 2, -1.0, 1.0)) * 180 / kPi, 45.0, 1e-9);
    EXPECT_LT((r.poses[k + 1].rotation * m_g + r.poses[k + 1].translation -
               (r.poses[k].rotation * m_g + r.poses[k].translation)).norm(), 1e-12);
  }
  // Lines best first by their pairs' count.
  for (std::size_t k = 8; k < r.poses.size(); k += 8) EXPECT_GE(r.poses[k - 8].votes, r.poses[k].votes);
}

TEST(Antipodal, EveryAntipodalPairTheJawSpansVotesAsABruteForceScanFindsThem) {
  const MovedBox b = moved_box(5);
  const PairIndex index = indexed(b);
  const Aligner aligner(index);
  const double cos_cone = std::cos(aligner.options().antipodal_cone);
  for (const double w : {0.03, 0.05, 0.07, 0.11}) {
    std::size_t expected = 0;
    const Points& P = b.facets.points;
    const Points& N = b.facets.normals;
    for (Eigen::Index i = 0; i < P.rows(); ++i)
      for (Eigen::Index j = i + 1; j < P.rows(); ++j) {
        Vector3d u = (P.row(j) - P.row(i)).transpose();
        const double d = u.norm();
        if (!(d > 0) || d > w) continue;
        u /= d;
        if (-N.row(i).dot(u) >= cos_cone && N.row(j).dot(u) >= cos_cone) ++expected;
      }
    const auto [p, n] = jaw(w);
    const AlignResult r = aligner.align_antipodal(p, n);
    EXPECT_EQ(r.stats.candidates, expected) << "w = " << w;
    EXPECT_EQ(expected == 0, r.poses.empty()) << "w = " << w;
    EXPECT_EQ(aligner.antipodal_count(p, n) == 0, expected == 0) << "w = " << w;
    // Across 6 cm too once the jaw spans it: lines along the box's y axis appear.
    std::set<int> axes;
    AlignerOptions o;
    o.max_poses = 1000;
    for (const AlignedPose& pose : Aligner(index, o).align_antipodal(p, n).poses) {
      const Vector3d a = b.R.transpose() * (pose.rotation * Vector3d(0, 1, 0));
      for (int k = 0; k < 3; ++k)
        if (std::abs(std::abs(a[k]) - 1) < 1e-9) axes.insert(k);
    }
    const std::set<int> spanned = w < 0.04 ? std::set<int>{} : w < 0.06 ? std::set<int>{0}
                                : w < 0.1 ? std::set<int>{0, 1} : std::set<int>{0, 1, 2};
    EXPECT_EQ(axes, spanned) << "w = " << w;
  }
}

TEST(Antipodal, ManyEqualsOneByOneAClosedJawAlignsNowhereAndBadPadsAreRefused) {
  const MovedBox b = moved_box(3);
  const PairIndex index = indexed(b);
  AlignerOptions o;
  o.threads = 2;
  const Aligner aligner(index, o);
  std::vector<Constellation> cs;
  for (const double w : {0.0, 0.045, 0.065, 0.09}) {
    Constellation c;
    std::tie(c.points, c.normals) = jaw(w);
    cs.push_back(c);
  }
  const auto many = aligner.align_antipodal_many(cs);
  ASSERT_EQ(many.size(), cs.size());
  EXPECT_TRUE(many[0].poses.empty());  // closed
  for (std::size_t k = 0; k < cs.size(); ++k) {
    const AlignResult one = aligner.align_antipodal(cs[k].points, cs[k].normals);
    ASSERT_EQ(one.poses.size(), many[k].poses.size());
    for (std::size_t i = 0; i < one.poses.size(); ++i) {
      EXPECT_EQ(one.poses[i].rotation, many[k].poses[i].rotation);
      EXPECT_EQ(one.poses[i].translation, many[k].poses[i].translation);
      EXPECT_EQ(one.poses[i].contacts, many[k].poses[i].contacts);
    }
  }
  auto [p, n] = jaw(0.05);
  Points away = n;
  away.row(0) *= -1.0;  // pad a faces away from pad b
  EXPECT_THROW(
      {
        try {
          aligner.align_antipodal(p, away);
        } catch (const std::invalid_argument& e) {
          EXPECT_NE(std::string(e.what()).find("normals: the pads' normals do not face each other"), std::string::npos);
          throw;
        }
      },
      std::invalid_argument);
  Points three(3, 3);
  three.setZero();
  EXPECT_THROW(aligner.align_antipodal(three, three), std::invalid_argument);
  AlignerOptions bad;
  bad.antipodal_rolls = 0;
  EXPECT_THROW(Aligner(index, bad), std::invalid_argument);
  bad = AlignerOptions();
  bad.antipodal_cone = 2.0;
  EXPECT_THROW(Aligner(index, bad), std::invalid_argument);
}

TEST(Antipodal, AnIndexOfOpposedPairsOnlyGivesTheSameLines) {
  // The planner stores only the pairs a jaw can use (normals opposed within twice the cone): the
  // index holds exactly those of the full index, and the lines are the same.
  const MovedBox b = moved_box(17);
  PairIndexOptions io;
  io.d_max = 0.12;
  const PairIndex full(b.facets.points, b.facets.normals, Mask(), io);
  io.max_normal_dot = -std::cos(2 * kDefaultAntipodalCone) + 1e-6;
  const PairIndex opposed(b.facets.points, b.facets.normals, Mask(), io);
  std::size_t expected = 0;
  for (Eigen::Index k = 0; k < full.pairs().rows(); ++k)
    expected += b.facets.normals.row(full.pairs()(k, 0)).dot(b.facets.normals.row(full.pairs()(k, 1))) <=
                io.max_normal_dot;
  EXPECT_EQ(opposed.size(), expected);
  EXPECT_LT(opposed.size() * 4, full.size());
  AlignerOptions o;
  o.max_poses = 1000;
  for (const double w : {0.05, 0.07, 0.11}) {
    const auto [p, n] = jaw(w);
    const AlignResult a = Aligner(full, o).align_antipodal(p, n), c = Aligner(opposed, o).align_antipodal(p, n);
    ASSERT_EQ(a.poses.size(), c.poses.size()) << "w = " << w;
    for (std::size_t i = 0; i < a.poses.size(); ++i) {
      EXPECT_EQ(a.poses[i].rotation, c.poses[i].rotation);
      EXPECT_EQ(a.poses[i].translation, c.poses[i].translation);
      EXPECT_EQ(a.poses[i].votes, c.poses[i].votes);
      EXPECT_EQ(a.poses[i].contacts, c.poses[i].contacts);
    }
  }
  io.max_normal_dot = std::nan("");
  EXPECT_THROW(PairIndex(b.facets.points, b.facets.normals, Mask(), io), std::invalid_argument);
}
