// The Aligner against known rigid transforms of patches cut from a tessellated target.
#include <pairgrasp/aligner.hpp>
#include <pairgrasp/facets.hpp>
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/versor.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <vector>

using namespace pairgrasp;
using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

constexpr double kEdge = 0.008;  // facet edge h, metres

// A closed, smooth, asymmetric "potato" of radius ~5 cm: a subdivided icosahedron whose radius
// is modulated by low-frequency terms (no symmetry, so a patch has one true place).
Mesh potato() {
  std::vector<Vector3d> v;
  std::vector<Eigen::Vector3i> f;
  const double g = (1 + std::sqrt(5.0)) / 2;
  const double iv[12][3] = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0}, {0, -1, g}, {0, 1, g},
                            {0, -1, -g}, {0, 1, -g}, {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
  for (auto& p : iv) v.push_back(Vector3d(p[0], p[1], p[2]).normalized());
  const int ifc[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                          {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                          {3, 8, 9},  {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (auto& a : ifc) f.emplace_back(a[0], a[1], a[2]);
  for (int s = 0; s < 4; ++s) {
    std::map<std::pair<int, int>, int> mid;
    std::vector<Eigen::Vector3i> nf;
    auto m = [&](int a, int b) {
      const auto k = std::minmax(a, b);
      const auto it = mid.find(k);
      if (it != mid.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      return mid[k] = static_cast<int>(v.size()) - 1;
    };
    for (auto& x : f) {
      const int a = m(x[0], x[1]), b = m(x[1], x[2]), c = m(x[2], x[0]);
      nf.emplace_back(x[0], a, c);
      nf.emplace_back(x[1], b, a);
      nf.emplace_back(x[2], c, b);
      nf.emplace_back(a, b, c);
    }
    f = nf;
  }
  Points V(static_cast<Eigen::Index>(v.size()), 3);
  Triangles F(static_cast<Eigen::Index>(f.size()), 3);
  for (std::size_t i = 0; i < v.size(); ++i) {
    const Vector3d d = v[i];
    const double r = 0.05 * (1 + 0.18 * std::sin(3 * d.x() + 1) * std::cos(2 * d.y()) +
                             0.12 * std::sin(4 * d.z() + 2 * d.x() + 0.5) + 0.1 * d.x() * d.y());
    V.row(static_cast<Eigen::Index>(i)) = (r * d).transpose();
  }
  for (std::size_t i = 0; i < f.size(); ++i) F.row(static_cast<Eigen::Index>(i)) = f[i].transpose();
  return make_mesh(V, F, "potato");
}

Matrix3d random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  Eigen::Quaterniond q(g(rng), g(rng), g(rng), g(rng));
  q.normalize();
  return q.toRotationMatrix();
}

double rot_deg(const Matrix3d& a, const Matrix3d& b) {
  return std::acos(std::clamp(((a.transpose() * b).trace() - 1) / 2, -1.0, 1.0)) * 180.0 / M_PI;
}

// A patch of target facets expressed as gripper samples: p_G = R^T (p_T - t), and the gripper
// normals point out of the finger, i.e. against the target's: n_G = -R^T n_T.
struct Patch {
  std::vector<int> facets;
  Points points, normals;
  Matrix3d R;
  Vector3d t;
};

Patch make_patch(const UnitFacets& uf, int centre, double radius, int count, std::mt19937_64& rng) {
  Patch p;
  for (Eigen::Index i = 0; i < uf.points.rows(); ++i)
    if ((uf.points.row(i) - uf.points.row(centre)).norm() < radius) p.facets.push_back(static_cast<int>(i));
  std::shuffle(p.facets.begin(), p.facets.end(), rng);
  if (count > 0 && static_cast<int>(p.facets.size()) > count) p.facets.resize(count);
  p.R = random_rotation(rng);
  std::normal_distribution<double> g(0.0, 0.1);
  p.t = Vector3d(g(rng), g(rng), g(rng));
  const auto n = static_cast<Eigen::Index>(p.facets.size());
  p.points.resize(n, 3);
  p.normals.resize(n, 3);
  for (Eigen::Index k = 0; k < n; ++k) {
    p.points.row(k) = (p.R.transpose() * (uf.points.row(p.facets[k]).transpose() - p.t)).transpose();
    p.normals.row(k) = (-(p.R.transpose() * uf.normals.row(p.facets[k]).transpose())).transpose();
  }
  return p;
}

// Largest distance between a patch sample moved by the pose and its target facet.
double max_displacement(const AlignedPose& pose, const Patch& p, const UnitFacets& uf) {
  double e = 0;
  for (Eigen::Index k = 0; k < p.points.rows(); ++k)
    e = std::max(e, (pose.rotation * p.points.row(k).transpose() + pose.translation -
                     uf.points.row(p.facets[k]).transpose()).norm());
  return e;
}

bool near_truth(const AlignedPose& pose, const Patch& p, const UnitFacets& uf) {
  return rot_deg(pose.rotation, p.R) < 1.0 && max_displacement(pose, p, uf) < 0.25 * kEdge;
}

class AlignerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    facets_ = new UnitFacets(tessellate(potato(), kEdge));
    PairIndexOptions o;
    o.d_max = 0.06;
    index_ = std::make_optional<PairIndex>(facets_->points, facets_->normals, Mask(), o);
  }
  static void TearDownTestSuite() {
    delete facets_;
    facets_ = nullptr;
    index_.reset();
  }
  static UnitFacets* facets_;
  static std::optional<PairIndex> index_;
};
UnitFacets* AlignerTest::facets_ = nullptr;
std::optional<PairIndex> AlignerTest::index_;

}  // namespace

TEST_F(AlignerTest, DefaultsComeFromTheIndexSpacing) {
  const Aligner a(*index_);
  const double h = index_->spacing();
  ASSERT_GT(h, 0.3 * kEdge);
  ASSERT_LT(h, 1.5 * kEdge);
  EXPECT_DOUBLE_EQ(a.options().feature_tolerance.x(), 0.5 * h);
  EXPECT_DOUBLE_EQ(a.options().feature_tolerance.y(), 0.1);
  EXPECT_DOUBLE_EQ(a.options().feature_tolerance.z(), 0.1);
  EXPECT_DOUBLE_EQ(a.options().angle_tolerance, 4.0 * M_PI / 180.0);
  EXPECT_DOUBLE_EQ(a.options().position_tolerance, 0.5 * h);
  AlignerOptions o;
  o.feature_tolerance = Vector3d(0.002, 0, 0.05);
  const Aligner b(*index_, o);
  EXPECT_DOUBLE_EQ(b.options().feature_tolerance.x(), 0.002);
  EXPECT_DOUBLE_EQ(b.options().feature_tolerance.y(), 0.1);
  EXPECT_DOUBLE_EQ(b.options().feature_tolerance.z(), 0.05);
}

TEST_F(AlignerTest, SevenPointPatchRecoveredAsTopPose) {
  const Aligner aligner(*index_);
  std::mt19937_64 rng(21);
  std::uniform_int_distribution<int> pick(0, static_cast<int>(facets_->points.rows()) - 1);
  for (int trial = 0; trial < 8; ++trial) {
    const Patch p = make_patch(*facets_, pick(rng), 0.025, 7, rng);
    ASSERT_EQ(p.facets.size(), 7u);
    const auto r = aligner.align(p.points, p.normals);
    ASSERT_FALSE(r.poses.empty()) << "trial " << trial;
    const auto& best = r.poses.front();
    EXPECT_LT(rot_deg(best.rotation, p.R), 1.0) << "trial " << trial;
    EXPECT_LT(max_displacement(best, p, *facets_), 0.25 * kEdge) << "trial " << trial;
    // 7 exactly matched contacts: every one of the 21 pairs agrees on three meetings.
    EXPECT_GE(best.votes, 3 * 7 * 6 / 2) << "trial " << trial;
    EXPECT_NEAR(best.quality, best.votes / (1 + best.variance), 1e-9);
    // The true contacts are among the matched ones.
    std::set<std::pair<int, int>> got;
    for (Eigen::Index k = 0; k < best.contacts.rows(); ++k) got.emplace(best.contacts(k, 0), best.contacts(k, 1));
    for (int k = 0; k < 7; ++k) EXPECT_TRUE(got.count({k, p.facets[k]})) << "trial " << trial << " sample " << k;
    for (std::size_t k = 1; k < r.poses.size(); ++k) EXPECT_LE(r.poses[k].quality, r.poses[k - 1].quality);
    EXPECT_FALSE(r.stats.saturated);
    EXPECT_EQ(r.stats.gripper_pairs, 21u);
  }
}

TEST_F(AlignerTest, AreaPatchVoteCountMatchesContactPairs) {
  // Every facet within 1.6 h of a centre: x contacts give 3 x(x-1)/2 votes (no gripper pair here
  // is collinear or beyond d_max).
  const Aligner aligner(*index_);
  std::mt19937_64 rng(22);
  const Patch p = make_patch(*facets_, 11, 1.6 * kEdge, 0, rng);
  const int x = static_cast<int>(p.facets.size());
  ASSERT_GE(x, 5);
  const auto r = aligner.align(p.points, p.normals);
  ASSERT_FALSE(r.poses.empty());
  EXPECT_TRUE(near_truth(r.poses.front(), p, *facets_));
  EXPECT_EQ(r.stats.collinear_pairs, 0u);
  EXPECT_GE(r.poses.front().votes, 3 * x * (x - 1) / 2);
  EXPECT_LE(r.poses.front().votes, 3 * x * (x - 1) / 2 + 3 * x);  // few extra near-misses
  EXPECT_EQ(r.poses.front().contacts.rows(), x);
}

TEST_F(AlignerTest, NoisyPatchStillRecovered) {
  // Sample positions jittered by 3% of h and normals by about half a degree.
  const Aligner aligner(*index_);
  std::mt19937_64 rng(23);
  std::normal_distribution<double> g;
  int ok = 0;
  for (int trial = 0; trial < 6; ++trial) {
    Patch p = make_patch(*facets_, 37 * trial + 5, 0.025, 7, rng);
    for (Eigen::Index k = 0; k < p.points.rows(); ++k) {
      p.points.row(k) += 0.03 * kEdge * Eigen::RowVector3d(g(rng), g(rng), g(rng));
      p.normals.row(k) = (p.normals.row(k) + 0.008 * Eigen::RowVector3d(g(rng), g(rng), g(rng))).normalized();
    }
    const auto r = aligner.align(p.points, p.normals);
    if (!r.poses.empty() && rot_deg(r.poses.front().rotation, p.R) < 1.0 &&
        max_displacement(r.poses.front(), p, *facets_) < 0.25 * kEdge)
      ++ok;
  }
  EXPECT_GE(ok, 5);
}

TEST_F(AlignerTest, GripperNormalsAreFlipped) {
  // Normals given like the target's (not pointing out of the finger) describe no contact.
  const Aligner aligner(*index_);
  std::mt19937_64 rng(24);
  for (int trial = 0; trial < 4; ++trial) {
    Patch p = make_patch(*facets_, 53 * trial + 9, 0.025, 7, rng);
    p.normals = -p.normals;
    const auto r = aligner.align(p.points, p.normals);
    for (const auto& pose : r.poses) EXPECT_FALSE(near_truth(pose, p, *facets_)) << "trial " << trial;
  }
}

TEST_F(AlignerTest, OccludedTargetFortyPercent) {
  // Paint occluded the 40% of facets farthest from a free centre; a patch near the centre is
  // found, a patch deep in the occluded part has no pose near its true transform.
  const Points& fp = facets_->points;
  const Eigen::Index n = fp.rows();
  const int centre = 100;
  std::vector<std::pair<double, int>> dist;
  for (Eigen::Index i = 0; i < n; ++i) dist.emplace_back((fp.row(i) - fp.row(centre)).norm(), static_cast<int>(i));
  std::sort(dist.begin(), dist.end());
  Mask free = Mask::Constant(n, true);
  const auto first_occluded = static_cast<std::size_t>(0.6 * static_cast<double>(n));
  for (std::size_t k = first_occluded; k < dist.size(); ++k) free[dist[k].second] = false;
  EXPECT_NEAR(1.0 - static_cast<double>(free.count()) / static_cast<double>(n), 0.4, 0.01);
  PairIndexOptions io;
  io.d_max = 0.06;
  const PairIndex index(facets_->points, facets_->normals, free, io);
  const Aligner aligner(index);
  std::mt19937_64 rng(25);
  for (int trial = 0; trial < 3; ++trial) {
    const Patch p = make_patch(*facets_, centre, 0.02, 7, rng);
    const auto r = aligner.align(p.points, p.normals);
    ASSERT_FALSE(r.poses.empty());
    EXPECT_TRUE(near_truth(r.poses.front(), p, *facets_)) << "trial " << trial;
  }
  const int far = dist.back().second;  // the most occluded facet; its 2 cm neighbourhood is occluded
  for (int trial = 0; trial < 3; ++trial) {
    const Patch p = make_patch(*facets_, far, 0.02, 7, rng);
    for (int f : p.facets) ASSERT_FALSE(free[f]);
    const auto r = aligner.align(p.points, p.normals);
    for (const auto& pose : r.poses) EXPECT_FALSE(near_truth(pose, p, *facets_)) << "trial " << trial;
    // Only free pairs are candidates: every matched contact is a free facet.
    for (const auto& pose : r.poses)
      for (Eigen::Index k = 0; k < pose.contacts.rows(); ++k) EXPECT_TRUE(free[pose.contacts(k, 1)]);
  }
}

TEST_F(AlignerTest, AlignManyEqualsSerialAndIsDeterministic) {
  std::mt19937_64 rng(26);
  std::vector<Constellation> cs;
  for (int k = 0; k < 4; ++k) {
    const Patch p = make_patch(*facets_, 29 * k + 3, 0.025, 6, rng);
    Constellation c;
    c.points = p.points;
    c.normals = p.normals;
    cs.push_back(c);
  }
  auto same = [](const AlignResult& a, const AlignResult& b) {
    if (a.poses.size() != b.poses.size()) return false;
    if (a.stats.rotation_votes != b.stats.rotation_votes || a.stats.correspondences != b.stats.correspondences)
      return false;
    for (std::size_t i = 0; i < a.poses.size(); ++i) {
      const auto &x = a.poses[i], &y = b.poses[i];
      if (x.rotation != y.rotation || x.translation != y.translation || x.votes != y.votes ||
          x.quality != y.quality || x.contacts != y.contacts)
        return false;
    }
    return true;
  };
  AlignerOptions o1;
  o1.threads = 1;
  const Aligner serial(*index_, o1);
  std::vector<AlignResult> ref;
  for (const auto& c : cs) ref.push_back(serial.align(c.points, c.normals));
  for (int threads : {2, 3}) {
    AlignerOptions o;
    o.threads = threads;
    const Aligner a(*index_, o);
    const auto many = a.align_many(cs);
    ASSERT_EQ(many.size(), cs.size());
    for (std::size_t k = 0; k < cs.size(); ++k) {
      EXPECT_TRUE(same(many[k], ref[k])) << "align_many, threads " << threads << ", constellation " << k;
      EXPECT_TRUE(same(a.align(cs[k].points, cs[k].normals), ref[k])) << "align, threads " << threads;
    }
  }
  EXPECT_TRUE(serial.align_many({}).empty());
}

TEST_F(AlignerTest, CapacitySaturationIsReported) {
  std::mt19937_64 rng(27);
  const Patch p = make_patch(*facets_, 77, 0.025, 7, rng);
  AlignerOptions o;
  o.capacity = 16;
  o.min_agreement = 1;
  const auto r = Aligner(*index_, o).align(p.points, p.normals);
  EXPECT_TRUE(r.stats.saturated);
  EXPECT_LE(r.stats.rotation_bins, 16u);
  EXPECT_GT(r.stats.dropped_rotation_votes, 0u);
  EXPECT_LT(r.stats.dropped_rotation_votes, r.stats.rotation_votes);
  for (const auto& pose : r.poses) {
    EXPECT_TRUE(pose.rotation.allFinite() && pose.translation.allFinite());
    EXPECT_TRUE(std::isfinite(pose.quality));
  }
  AlignerOptions c;
  c.max_correspondences = 1000;
  const auto rc = Aligner(*index_, c).align(p.points, p.normals);
  EXPECT_TRUE(rc.stats.saturated);
  EXPECT_GT(rc.stats.correspondences, 1000u);
  EXPECT_LE(rc.stats.correspondences_used, 1000u);
  EXPECT_GE(rc.stats.correspondences_used, 500u);
  // Without pressure nothing is flagged.
  const auto ok = Aligner(*index_).align(p.points, p.normals);
  EXPECT_FALSE(ok.stats.saturated);
  EXPECT_EQ(ok.stats.dropped_rotation_votes, 0u);
}

TEST_F(AlignerTest, AntipodalGripperPairIsSkipped) {
  // Two pads facing each other across their connecting line: the roll is free, nothing votes.
  Points pts(2, 3), nrm(2, 3);
  pts << 0, 0, 0, 0.04, 0, 0;
  nrm << 1, 0, 0, -1, 0, 0;
  const auto r = Aligner(*index_).align(pts, nrm);
  EXPECT_EQ(r.stats.collinear_pairs, 1u);
  EXPECT_EQ(r.stats.correspondences, 0u);
  EXPECT_TRUE(r.poses.empty());
}

TEST_F(AlignerTest, BadInputThrows) {
  const Aligner a(*index_);
  Points p3(3, 3), n2(2, 3), p1(1, 3);
  p3.setZero();
  n2 << 0, 0, 1, 0, 0, 1;
  p1.setZero();
  try {
    a.align(p3, n2);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "normals: expected (3,3) like points, got (2,3)");
  }
  EXPECT_THROW(a.align(p1, n2.topRows(1)), std::invalid_argument);
  Points p2 = p3.topRows(2);
  Points bad = n2;
  bad(0, 2) = 2;
  EXPECT_THROW(a.align(p2, bad), std::invalid_argument);
  p2(1, 0) = std::nan("");
  EXPECT_THROW(a.align(p2, n2), std::invalid_argument);
  Constellation c;
  c.points = p3;
  c.normals = n2;
  try {
    a.align_many({c});
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("constellations[0]: normals"), std::string::npos);
  }
  AlignerOptions o;
  o.capacity = 0;
  EXPECT_THROW(Aligner(*index_, o), std::invalid_argument);
  o = AlignerOptions();
  o.angle_tolerance = -1;
  EXPECT_THROW(Aligner(*index_, o), std::invalid_argument);
  o = AlignerOptions();
  o.feature_tolerance = Vector3d(std::nan(""), 0, 0);
  EXPECT_THROW(Aligner(*index_, o), std::invalid_argument);
  o = AlignerOptions();
  o.max_poses = 0;
  EXPECT_THROW(Aligner(*index_, o), std::invalid_argument);
  o = AlignerOptions();
  o.threads = -2;
  EXPECT_THROW(Aligner(*index_, o), std::invalid_argument);
}

// The pre-filter only skips correspondences the solver would reject: with it on and off, the
// poses are bit for bit the same and so is every count (the rejected ones are counted as the
// solver counts them), on patches, noisy patches and random constellations, for several
// tolerances, with and without thinning.
TEST_F(AlignerTest, PrefilterChangesNothingButTheWork) {
  std::mt19937_64 rng(57);
  std::uniform_int_distribution<int> pick(0, static_cast<int>(facets_->points.rows()) - 1);
  std::normal_distribution<double> g;
  std::vector<std::pair<Points, Points>> cs;
  for (int k = 0; k < 6; ++k) {
    Patch p = make_patch(*facets_, pick(rng), 0.03, 5 + k % 4, rng);
    if (k % 2 == 1)
      for (Eigen::Index r = 0; r < p.points.rows(); ++r) {
        p.points.row(r) += 0.001 * Eigen::RowVector3d(g(rng), g(rng), g(rng));
        p.normals.row(r) = (p.normals.row(r) + 0.03 * Eigen::RowVector3d(g(rng), g(rng), g(rng))).normalized();
      }
    cs.emplace_back(p.points, p.normals);
  }
  for (int k = 0; k < 4; ++k) {  // random oriented points within a 5 cm ball
    Points P(6, 3), N(6, 3);
    for (Eigen::Index r = 0; r < 6; ++r) {
      P.row(r) = 0.025 * Eigen::RowVector3d(g(rng), g(rng), g(rng));
      N.row(r) = Eigen::RowVector3d(g(rng), g(rng), g(rng)).normalized();
    }
    cs.emplace_back(P, N);
  }
  std::size_t prefiltered = 0, solved = 0;
  for (int variant = 0; variant < 4; ++variant) {
    AlignerOptions o;
    o.threads = 1 + variant % 2;
    if (variant == 1) o.angle_tolerance = 0.02;
    if (variant == 2) o.angle_tolerance = 0.12, o.collinear_tolerance = 0.3;
    if (variant == 3) o.max_correspondences = 700;  // thinned
    o.prefilter = false;
    const Aligner before(*index_, o);
    o.prefilter = true;
    const Aligner now(*index_, o);
    for (std::size_t c = 0; c < cs.size(); ++c) {
      const AlignResult a = before.align(cs[c].first, cs[c].second);
      const AlignResult b = now.align(cs[c].first, cs[c].second);
      const std::string where = "variant " + std::to_string(variant) + " constellation " + std::to_string(c);
      const AlignStats &x = a.stats, &y = b.stats;
      EXPECT_EQ(x.prefiltered, 0u);
      prefiltered += y.prefiltered;
      solved += y.correspondences_used - y.prefiltered;
      EXPECT_EQ(x.gripper_pairs, y.gripper_pairs) << where;
      EXPECT_EQ(x.collinear_pairs, y.collinear_pairs) << where;
      EXPECT_EQ(x.correspondences, y.correspondences) << where;
      EXPECT_EQ(x.correspondences_used, y.correspondences_used) << where;
      EXPECT_EQ(x.underdetermined, y.underdetermined) << where;
      EXPECT_EQ(x.no_agreement, y.no_agreement) << where;
      EXPECT_EQ(x.candidates, y.candidates) << where;
      EXPECT_EQ(x.rotation_votes, y.rotation_votes) << where;
      EXPECT_EQ(x.dropped_rotation_votes, y.dropped_rotation_votes) << where;
      EXPECT_EQ(x.rotation_bins, y.rotation_bins) << where;
      EXPECT_EQ(x.rotation_clusters, y.rotation_clusters) << where;
      EXPECT_EQ(x.position_votes, y.position_votes) << where;
      EXPECT_EQ(x.dropped_position_votes, y.dropped_position_votes) << where;
      EXPECT_EQ(x.position_bins, y.position_bins) << where;
      EXPECT_EQ(x.saturated, y.saturated) << where;
      ASSERT_EQ(a.poses.size(), b.poses.size()) << where;
      for (std::size_t i = 0; i < a.poses.size(); ++i) {
        const AlignedPose &p = a.poses[i], &q = b.poses[i];
        EXPECT_TRUE(p.rotation == q.rotation && p.translation == q.translation && p.votes == q.votes &&
                    p.quality == q.quality && p.variance == q.variance && p.position_rms == q.position_rms &&
                    p.angle_rms == q.angle_rms && p.correspondences == q.correspondences && p.contacts == q.contacts)
            << where << " pose " << i;
      }
    }
  }
  // The filter did its work: most correspondences never reached the solver.
  EXPECT_GT(prefiltered, solved);
}
