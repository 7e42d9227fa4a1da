// PairIndex: stored pairs, features and queries against brute force; invariances; budget; bad input.
#include <gtest/gtest.h>
#include <pairgrasp/error.hpp>
#include <pairgrasp/features.hpp>
#include <pairgrasp/pair_index.hpp>

#include "../../cpp/src/pair_index_internal.hpp"
#include "surface_test_meshes.hpp"
#include "test_scale.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <random>
#include <regex>
#include <set>
#include <string>
#include <utility>

using namespace pairgrasp;
using namespace surface_test;

namespace {

using PairSet = std::set<std::pair<int, int>>;

struct Cloud {
  Points p, n;
};

// Points near a sphere of radius r (radial noise), normals radial plus noise, renormalised.
Cloud sphere_cloud(int count, double r, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  Cloud c{Points(count, 3), Points(count, 3)};
  for (int i = 0; i < count; ++i) {
    Eigen::Vector3d d(g(rng), g(rng), g(rng));
    d.normalize();
    c.p.row(i) = (r * (1.0 + 0.05 * g(rng)) * d).transpose();
    Eigen::Vector3d n = d + 0.3 * Eigen::Vector3d(g(rng), g(rng), g(rng));
    c.n.row(i) = n.normalized().transpose();
  }
  return c;
}

PairSet brute_pairs(const Points& p, double d_max, const Mask& free = Mask()) {
  PairSet out;
  for (int i = 0; i < p.rows(); ++i)
    for (int j = i + 1; j < p.rows(); ++j)
      if ((free.size() == 0 || (free[i] && free[j])) && (p.row(i) - p.row(j)).norm() <= d_max) out.insert({i, j});
  return out;
}

PairSet stored_pairs(const PairIndex& idx) {
  PairSet out;
  for (Eigen::Index k = 0; k < idx.pairs().rows(); ++k) out.insert({idx.pairs()(k, 0), idx.pairs()(k, 1)});
  return out;
}

// The paper's definition, term by term: beta_ij = n_i . (p_i - p_j) / d, beta_ji = n_j . (p_j - p_i) / d.
Eigen::Vector3d reference_feature(const Points& p, const Points& n, int i, int j) {
  const Eigen::Vector3d pi = p.row(i).transpose(), pj = p.row(j).transpose();
  const Eigen::Vector3d ni = n.row(i).transpose(), nj = n.row(j).transpose();
  const double d = (pi - pj).norm();
  return {d, ni.dot(nj), ni.dot(pi - pj) / d + nj.dot(pj - pi) / d};
}

std::vector<std::uint32_t> brute_query(const PairIndex& idx, const Eigen::Vector3d& c, const Eigen::Vector3d& t) {
  std::vector<std::uint32_t> out;
  const auto& f = idx.features();
  for (Eigen::Index k = 0; k < f.rows(); ++k) {
    bool in = true;
    for (int a = 0; a < 3; ++a) in = in && std::abs(double(f(k, a)) - c[a]) <= t[a];
    if (in) out.push_back(std::uint32_t(k));
  }
  return out;
}

// Random boxes: around stored features, exact (zero tolerance), empty, huge; query == brute force.
void check_queries(const PairIndex& idx, unsigned seed, int count) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const auto& f = idx.features();
  ASSERT_GT(f.rows(), 0);
  std::uniform_int_distribution<Eigen::Index> pick(0, f.rows() - 1);
  int nonempty = 0;
  for (int q = 0; q < count; ++q) {
    Eigen::Vector3d c = f.row(pick(rng)).cast<double>().transpose();
    Eigen::Vector3d t;
    const int kind = q % 8;
    if (kind == 0) {  // typical: (2.5 mm, 0.05, 0.05) scaled
      t = Eigen::Vector3d(0.0025, 0.05, 0.05) * std::exp(2.0 * g(rng));
      c += Eigen::Vector3d(t[0] * g(rng), t[1] * g(rng), t[2] * g(rng));
    } else if (kind == 1) {  // a stored feature exactly, zero tolerance: at least that pair
      t.setZero();
    } else if (kind == 2) {  // far outside: empty
      c += Eigen::Vector3d(10.0, 5.0, 9.0) * (u(rng) < 0.5 ? 1.0 : -1.0);
      t = Eigen::Vector3d(0.01, 0.1, 0.1);
    } else if (kind == 3) {  // huge: everything
      t = Eigen::Vector3d::Constant(1e6);
    } else if (kind == 5) {  // a stored feature exactly on a face of the box
      t = Eigen::Vector3d(0.0025, 0.05, 0.05) * std::exp(g(rng));
      const int a = int(q / 6) % 3;
      c[a] += (q % 4 < 2 ? 1.0 : -1.0) * t[a];
    } else if (kind == 6) {  // tolerances beyond float range or infinite on some axes
      t = Eigen::Vector3d(0.0025, 0.05, 0.05);
      t[q / 8 % 3] = (q / 24) % 2 ? std::numeric_limits<double>::infinity() : 1e300;
    } else if (kind == 7) {  // a box edge half a float step from stored features (rounding of the ends)
      t = Eigen::Vector3d(0.0025, 0.05, 0.05) * std::exp(g(rng));
      const int a = q / 8 % 3;
      const double step = std::nextafter(float(c[a]), std::numeric_limits<float>::infinity()) - float(c[a]);
      c[a] += ((q / 24) % 2 ? 1.0 : -1.0) * (t[a] + 0.5 * step);
    } else {  // random box anywhere in the feature range, anisotropic
      c = Eigen::Vector3d(0.1 * u(rng), 2 * u(rng) - 1, 4 * u(rng) - 2);
      t = Eigen::Vector3d(0.02 * u(rng), 0.5 * u(rng), 0.5 * u(rng));
    }
    const auto got = idx.query(c, t);  // documented: in increasing order, hence no duplicates
    const auto want = brute_query(idx, c, t);
    ASSERT_EQ(got, want) << "query " << q << " kind " << kind;
    ASSERT_EQ(idx.count(c, t), want.size()) << "count " << q << " kind " << kind;
    if (kind == 1) EXPECT_GE(got.size(), 1u);
    if (kind == 2) EXPECT_TRUE(got.empty());
    if (kind == 3) EXPECT_EQ(got.size(), idx.size());
    nonempty += !got.empty();
  }
  EXPECT_GT(nonempty, count / 2);
}

}  // namespace

TEST(PairFeature, MatchesDefinitionAndIsSymmetric) {
  const Cloud c = sphere_cloud(50, 0.05, 1);
  for (int i = 0; i < 50; ++i)
    for (int j = 0; j < 50; ++j) {
      if (i == j) continue;
      const Eigen::Vector3d e = pair_feature(c.p.row(i).transpose(), c.n.row(i).transpose(), c.p.row(j).transpose(),
                                             c.n.row(j).transpose());
      const Eigen::Vector3d r = reference_feature(c.p, c.n, i, j);
      EXPECT_LT((e - r).cwiseAbs().maxCoeff(), 1e-12);
      const Eigen::Vector3d s = pair_feature(c.p.row(j).transpose(), c.n.row(j).transpose(), c.p.row(i).transpose(),
                                             c.n.row(i).transpose());
      EXPECT_EQ(e, s) << "not symmetric bit for bit";
    }
  // A hand computation: p_i = 0, n_i = x; p_j = (0.03, 0.04, 0), n_j = y.
  const Eigen::Vector3d e = pair_feature(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(),
                                         Eigen::Vector3d(0.03, 0.04, 0), Eigen::Vector3d::UnitY());
  EXPECT_NEAR(e[0], 0.05, 1e-15);
  EXPECT_NEAR(e[1], 0.0, 1e-15);
  EXPECT_NEAR(e[2], (-0.03 + 0.04) / 0.05, 1e-15);  // (x - y) . (-0.03, -0.04, 0) / 0.05
  // Coincident points: third component 0, not NaN.
  const Eigen::Vector3d z = pair_feature(Eigen::Vector3d::Ones(), Eigen::Vector3d::UnitX(), Eigen::Vector3d::Ones(),
                                         Eigen::Vector3d::UnitY());
  EXPECT_EQ(z, Eigen::Vector3d(0, 0, 0));
  EXPECT_THROW(pair_feature(Eigen::Vector3d::Zero(), Eigen::Vector3d(1, 1, 0), Eigen::Vector3d::Ones(),
                            Eigen::Vector3d::UnitY()),
               std::invalid_argument);
  EXPECT_THROW(pair_feature(Eigen::Vector3d::Constant(NAN), Eigen::Vector3d::UnitX(), Eigen::Vector3d::Ones(),
                            Eigen::Vector3d::UnitY()),
               std::invalid_argument);
}

TEST(PairIndex, StoresExactlyThePairsWithinDmax) {
  const Cloud c = sphere_cloud(700, 0.05, 2);
  for (double d_max : {0.005, 0.03, 0.2}) {
    PairIndexOptions o;
    o.d_max = d_max;
    const PairIndex idx(c.p, c.n, Mask(), o);
    const PairSet want = brute_pairs(c.p, d_max);
    EXPECT_EQ(idx.size(), want.size());
    EXPECT_EQ(stored_pairs(idx), want) << "d_max " << d_max;
    EXPECT_EQ(count_pairs(c.p, d_max), want.size());
    for (Eigen::Index k = 0; k < idx.pairs().rows(); ++k) EXPECT_LT(idx.pairs()(k, 0), idx.pairs()(k, 1));
  }
  // Everything within d_max: exactly N (N - 1) / 2 pairs.
  PairIndexOptions all;
  all.d_max = 1.0;
  EXPECT_EQ(PairIndex(c.p, c.n, Mask(), all).size(), 700u * 699u / 2u);
}

TEST(PairIndex, FeaturesMatchAnIndependentComputation) {
  const Cloud c = sphere_cloud(400, 0.05, 3);
  PairIndexOptions o;
  o.d_max = 0.04;
  const PairIndex idx(c.p, c.n, Mask(), o);
  ASSERT_GT(idx.size(), 1000u);
  double worst = 0.0;
  for (Eigen::Index k = 0; k < idx.pairs().rows(); ++k) {
    const Eigen::Vector3d r = reference_feature(c.p, c.n, idx.pairs()(k, 0), idx.pairs()(k, 1));
    worst = std::max(worst, (idx.features().row(k).cast<double>().transpose() - r).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-6);  // float32 storage
}

TEST(PairIndex, FeaturesInvariantUnderRigidMotion) {
  const Cloud c = sphere_cloud(300, 0.05, 4);
  std::mt19937 rng(5);
  std::normal_distribution<double> g;
  PairIndexOptions o;
  o.d_max = 0.05;
  const PairIndex a(c.p, c.n, Mask(), o);
  std::map<std::pair<int, int>, Eigen::Vector3f> fa;
  for (Eigen::Index k = 0; k < a.pairs().rows(); ++k) fa[{a.pairs()(k, 0), a.pairs()(k, 1)}] = a.features().row(k);
  for (int trial = 0; trial < 3; ++trial) {
    const Eigen::Matrix3d R = Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
    const Eigen::RowVector3d t(g(rng), g(rng), g(rng));
    Points p = (c.p * R.transpose()).rowwise() + t;
    Points n = c.n * R.transpose();
    const PairIndex b(p, n, Mask(), o);
    ASSERT_EQ(b.size(), a.size());  // no pair sits within 1e-12 of d_max here
    double worst = 0.0;
    for (Eigen::Index k = 0; k < b.pairs().rows(); ++k) {
      auto it = fa.find({b.pairs()(k, 0), b.pairs()(k, 1)});
      ASSERT_NE(it, fa.end());
      worst = std::max(worst, double((b.features().row(k) - it->second.transpose()).cwiseAbs().maxCoeff()));
    }
    EXPECT_LT(worst, 2e-6);
  }
}

TEST(PairIndex, PairGeometryMatchesAnIndependentComputation) {
  const Cloud c = sphere_cloud(500, 0.05, 8);
  const Points &P = c.p, &N = c.n;
  PairIndexOptions o;
  o.d_max = 0.04;
  const PairIndex index(P, N, Mask(), o);
  const auto& g = index.pair_geometry();
  ASSERT_EQ(std::size_t(g.rows()), index.size());
  const double ang = M_PI / PairIndex::kGeometryScale, inv = 1.0 / PairIndex::kGeometryScale;
  for (std::size_t k = 0; k < index.size(); ++k) {
    const int i = index.pairs()(k, 0), j = index.pairs()(k, 1);
    const Eigen::Vector3d ni = N.row(i).transpose(), nj = N.row(j).transpose();
    const Eigen::Vector3d u = (P.row(j) - P.row(i)).transpose().normalized();
    EXPECT_NEAR(g(k, 0) * ang, std::acos(std::clamp(ni.dot(nj), -1.0, 1.0)), 1e-4);
    EXPECT_NEAR(g(k, 1) * ang, std::acos(std::clamp(ni.dot(u), -1.0, 1.0)), 1e-4);
    EXPECT_NEAR(g(k, 2) * ang, std::acos(std::clamp(nj.dot(u), -1.0, 1.0)), 1e-4);
    EXPECT_NEAR(g(k, 3) * inv, ni.cross(nj).dot(u), 1e-4);
  }
  // 2 int32 + 3 float32 + 4 int16 per pair (28 bytes), plus the tree (24 bytes per node, at
  // most 3 bytes per pair with leaves of 16 or more pairs) and the points.
  const double per_pair = double(index.nbytes() - std::size_t(P.size() + N.size()) * sizeof(double)) / double(index.size());
  EXPECT_GE(per_pair, 28.0);
  EXPECT_LE(per_pair, 31.5);
}

TEST(PairIndex, FreeMaskKeepsOnlyFreePairs) {
  const Cloud c = sphere_cloud(500, 0.05, 6);
  Mask free(500);
  for (int i = 0; i < 500; ++i) free[i] = c.p(i, 2) > -0.01;
  PairIndexOptions o;
  o.d_max = 0.03;
  const PairIndex idx(c.p, c.n, free, o);
  EXPECT_EQ(stored_pairs(idx), brute_pairs(c.p, 0.03, free));
  EXPECT_EQ(count_pairs(c.p, 0.03, free), idx.size());
  const PairIndex none(c.p, c.n, Mask::Constant(500, false), o);
  EXPECT_EQ(none.size(), 0u);
  EXPECT_TRUE(none.query(Eigen::Vector3d(0.01, 0, 0), Eigen::Vector3d::Constant(1e9)).empty());
}

TEST(PairIndex, QueryEqualsBruteForceOnRandomFeatures) {
  const Cloud c = sphere_cloud(600, 0.05, 7);
  PairIndexOptions o;
  o.d_max = 0.06;
  const PairIndex idx(c.p, c.n, Mask(), o);
  ASSERT_GT(idx.depth(), 6);
  check_queries(idx, 8, 300);
}

TEST(PairIndex, QueryEqualsBruteForceOnMeshFeatures) {
  // Real surfaces: many equal features (planes, a cylinder), where ties at box faces are common.
  for (const Mesh& m : {fan_cylinder(0.03, 0.08, 48), box(0.06, 0.06, 0.12)}) {
    const UnitFacets u = tessellate(m, 0.008);
    PairIndexOptions o;
    o.d_max = 0.1;
    const PairIndex idx(u.points, u.normals, u.free, o);
    check_queries(idx, 9, testing_scale::cases(150));
  }
}

TEST(PairIndex, SmallAndEmptyIndexes) {
  const Cloud c = sphere_cloud(20, 0.05, 10);
  PairIndexOptions o;
  o.d_max = 0.2;
  const PairIndex small(c.p, c.n, Mask(), o);  // 190 pairs: a few levels
  check_queries(small, 11, 50);
  const PairIndex one(c.p.topRows(1), c.n.topRows(1), Mask(), o);
  EXPECT_EQ(one.size(), 0u);
  EXPECT_EQ(one.spacing(), 0.0);
  EXPECT_TRUE(one.query(Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(1e9)).empty());
  const PairIndex two(c.p.topRows(2), c.n.topRows(2), Mask(), o);
  EXPECT_EQ(two.size(), 1u);
  EXPECT_EQ(two.depth(), 0);
  EXPECT_EQ(two.query(Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(1e9)).size(), 1u);
}

TEST(PairIndex, TreeIsBalancedAndBoxesEnclose) {
  const Cloud c = sphere_cloud(500, 0.05, 12);
  PairIndexOptions o;
  o.d_max = 0.05;
  const PairIndex idx(c.p, c.n, Mask(), o);
  const std::size_t m = idx.size();
  const int depth = idx.depth();
  const auto& boxes = idx.node_boxes();
  ASSERT_EQ(boxes.size(), 6 * ((std::size_t(2) << depth) - 1));
  // Walk the implicit ranges: every node's box is the exact bound of its range.
  std::vector<std::tuple<std::size_t, std::size_t, std::size_t, int>> stack = {{0, 0, m, 0}};
  std::size_t leaves = 0;
  while (!stack.empty()) {
    auto [node, b, e, level] = stack.back();
    stack.pop_back();
    for (int a = 0; a < 3; ++a) {
      float lo = INFINITY, hi = -INFINITY;
      for (std::size_t k = b; k < e; ++k) lo = std::min(lo, idx.features()(k, a)), hi = std::max(hi, idx.features()(k, a));
      EXPECT_EQ(boxes[6 * node + a], lo);
      EXPECT_EQ(boxes[6 * node + 3 + a], hi);
    }
    if (level == depth) {
      ++leaves;
      EXPECT_GE(e - b, 16u);
      EXPECT_LE(e - b, 32u);
      continue;
    }
    const std::size_t mid = b + (e - b) / 2;
    stack.push_back({2 * node + 1, b, mid, level + 1});
    stack.push_back({2 * node + 2, mid, e, level + 1});
  }
  EXPECT_EQ(leaves, std::size_t(1) << depth);
}

TEST(PairIndex, DeterministicAcrossThreadCounts) {
  const Cloud c = sphere_cloud(800, 0.05, 13);
  PairIndexOptions o;
  o.d_max = 0.04;
  o.threads = 1;
  const PairIndex a(c.p, c.n, Mask(), o);
  o.threads = 3;
  const PairIndex b(c.p, c.n, Mask(), o);
  EXPECT_EQ(a.pairs(), b.pairs());
  EXPECT_EQ(a.features(), b.features());
  EXPECT_EQ(a.node_boxes(), b.node_boxes());
}

TEST(PairIndex, SpacingIsTheMedianNearestNeighbourDistance) {
  // A 30 x 20 grid of spacing 4 mm: every nearest neighbour is 4 mm away.
  Points p(600, 3), n(600, 3);
  for (int i = 0; i < 600; ++i) {
    p.row(i) << 0.004 * (i % 30), 0.004 * (i / 30), 0.0;
    n.row(i) << 0, 0, 1;
  }
  PairIndexOptions o;
  o.d_max = 0.01;
  const PairIndex idx(p, n, Mask(), o);
  EXPECT_NEAR(idx.spacing(), 0.004, 1e-12);
  EXPECT_DOUBLE_EQ(idx.d_max(), 0.01);
  EXPECT_EQ(idx.points(), p);
  EXPECT_EQ(idx.normals(), n);
  // nbytes: at least 8 + 12 + 8 bytes per pair, and the tree adds little.
  EXPECT_GE(idx.nbytes(), 28 * idx.size());
  EXPECT_LE(idx.nbytes(), 34 * idx.size() + 49 * 600 + 4096);
}

TEST(PairIndex, BudgetRefusalNamesWhatFits) {
  const Cloud c = sphere_cloud(1000, 0.05, 14);
  PairIndexOptions o;
  o.d_max = 0.2;  // beyond the diameter: all 499,500 pairs
  o.max_pairs = 100000;
  std::string msg;
  try {
    PairIndex idx(c.p, c.n, Mask(), o);
    FAIL() << "no BudgetError";
  } catch (const BudgetError& e) {
    msg = e.what();
  }
  EXPECT_NE(msg.find("499500 pairs"), std::string::npos) << msg;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(msg, m, std::regex("about ([0-9]+) facets would fit"))) << msg;
  const long fit = std::stol(m[1]);
  // fit (fit - 1) / 2 <= 100000 < (fit + 2)(fit + 1) / 2: the largest count that fits, give or take one.
  EXPECT_LE(fit * (fit - 1) / 2, 100000);
  EXPECT_GT((fit + 2) * (fit + 1) / 2, 100000);
  ASSERT_TRUE(std::regex_search(msg, m, std::regex("x([0-9.]+)"))) << msg;
  EXPECT_NEAR(std::stod(m[1]), std::pow(499500.0 / 100000.0, 0.25), 0.01);
  // And it fits indeed.
  const PairIndex ok(c.p.topRows(fit), c.n.topRows(fit), Mask(), o);
  EXPECT_LE(ok.size(), 100000u);
  EXPECT_THROW(PairIndex(c.p, c.n, Mask(), o), std::invalid_argument);  // a BudgetError is one
}

TEST(PairIndex, BadInput) {
  const Cloud c = sphere_cloud(10, 0.05, 15);
  PairIndexOptions o;
  EXPECT_THROW(PairIndex(c.p, c.n.topRows(9), Mask(), o), std::invalid_argument);
  EXPECT_THROW(PairIndex(c.p, c.n, Mask::Constant(3, true), o), std::invalid_argument);
  Points nan = c.p;
  nan(4, 1) = NAN;
  EXPECT_THROW(PairIndex(nan, c.n, Mask(), o), std::invalid_argument);
  Points long_normals = c.n * 1.1;
  try {
    PairIndex(c.p, long_normals, Mask(), o);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("normals: row 0"), std::string::npos) << e.what();
  }
  for (double d : {0.0, -1.0, double(NAN), double(INFINITY)}) {
    o.d_max = d;
    EXPECT_THROW(PairIndex(c.p, c.n, Mask(), o), std::invalid_argument) << d;
    EXPECT_THROW(count_pairs(c.p, d), std::invalid_argument);
  }
  o.d_max = 0.2;
  const PairIndex idx(c.p, c.n, Mask(), o);
  EXPECT_THROW(idx.query(Eigen::Vector3d(NAN, 0, 0), Eigen::Vector3d::Ones()), std::invalid_argument);
  EXPECT_THROW(idx.query(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.1, -0.1, 0.1)), std::invalid_argument);
  EXPECT_THROW(idx.query(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.1, NAN, 0.1)), std::invalid_argument);
  EXPECT_THROW(idx.count(Eigen::Vector3d(0, INFINITY, 0), Eigen::Vector3d::Ones()), std::invalid_argument);
}

TEST(SuggestEdge, FinestEdgeThatFitsTheBudget) {
  const Mesh m = icosphere(0.05, 3);
  const std::size_t budget = 200000;
  const double edge = suggest_edge(m, 0.2, budget);
  const UnitFacets u = tessellate(m, edge);
  const std::size_t pairs = count_pairs(u.points, 0.2, u.free);
  EXPECT_LE(pairs, budget);
  // Finest: 5% finer no longer fits (pairs grow as edge^-4: about +23%).
  const UnitFacets finer = tessellate(m, edge / 1.05);
  EXPECT_GT(count_pairs(finer.points, 0.2, finer.free), budget);
  EXPECT_THROW(suggest_edge(m, 0.0, budget), std::invalid_argument);
  EXPECT_THROW(suggest_edge(m, 0.2, 0), std::invalid_argument);
  EXPECT_THROW(suggest_edge(m, 0.2, budget, Mask(), -0.001), std::invalid_argument);
  EXPECT_THROW(suggest_edge(m, 0.2, budget, Mask(), NAN), std::invalid_argument);
  // A finest edge wanted: kept when it fits (counted), otherwise the budget decides.
  EXPECT_EQ(suggest_edge(m, 0.2, budget, Mask(), 1.2 * edge), 1.2 * edge);
  EXPECT_DOUBLE_EQ(suggest_edge(m, 0.2, budget, Mask(), edge / 1.05), edge);

  PairIndexOptions o;
  o.d_max = 0.2;
  o.max_pairs = budget;
  const TargetIndex t = build_target_index(m, 0.0, Mask(), o);
  EXPECT_DOUBLE_EQ(t.facets.edge, edge);
  EXPECT_EQ(t.index.size(), pairs);
  EXPECT_EQ(t.index.points(), t.facets.points);
}

// The planner's handover: the unit facets suggesting an edge made are the tessellation at that edge,
// and the index built from them is the one build_target_index() builds by tessellating.
TEST(SuggestEdge, HandsOverTheTessellationOfTheEdgeItReturns) {
  const Mesh m = icosphere(0.05, 3);
  const std::size_t budget = 200000;
  Mask free(m.faces.rows());
  for (Eigen::Index f = 0; f < free.size(); ++f) free[f] = m.vertices(m.faces(f, 0), 2) > -0.02;
  PairIndexOptions o;
  o.d_max = 0.2;
  o.max_pairs = budget;
  const double fits = suggest_edge(m, 0.2, budget, free);
  // Both ways of returning: the finest edge wanted fits (counted there), or the budget decides.
  for (const double wanted : {1.2 * fits, fits / 1.05, 0.0}) {
    std::optional<UnitFacets> handed;
    const double edge = detail::suggest_edge(m, 0.2, budget, free, wanted, &handed);
    EXPECT_EQ(edge, suggest_edge(m, 0.2, budget, free, wanted));
    ASSERT_TRUE(handed.has_value()) << wanted;
    const UnitFacets made = tessellate(m, edge, free);
    EXPECT_EQ(handed->edge, made.edge);
    EXPECT_EQ(handed->points, made.points);
    EXPECT_EQ(handed->normals, made.normals);
    EXPECT_EQ(handed->free, made.free);
    const TargetIndex from_handed = detail::build_target_index(m, edge, free, o, std::move(handed));
    const TargetIndex built = build_target_index(m, edge, free, o);
    EXPECT_EQ(from_handed.index.pairs(), built.index.pairs());
    EXPECT_EQ(from_handed.index.features(), built.index.features());
  }
}

TEST(BuildTargetIndex, RefusedEdgeNamesTheEdgeThatFits) {
  // An icosphere of radius 5 cm at a 2 mm edge: ~7,000 facets, every pair within d_max = 0.2,
  // ~2.5e7 pairs against a budget of 2e5.
  const Mesh m = icosphere(0.05, 3);
  PairIndexOptions o;
  o.d_max = 0.2;
  o.max_pairs = 200000;
  std::string msg;
  try {
    build_target_index(m, 0.002, Mask(), o);
    FAIL() << "no BudgetError";
  } catch (const BudgetError& e) {
    msg = e.what();
  }
  EXPECT_EQ(msg.rfind("max_pairs: at a facet edge of 0.002 m", 0), 0u) << msg;
  std::smatch match;
  ASSERT_TRUE(std::regex_search(msg, match, std::regex("a facet edge of ([0-9.e-]+) m fits"))) << msg;
  const double fit = std::stod(match[1]);
  EXPECT_GE(fit, suggest_edge(m, 0.2, o.max_pairs));
  // The named edge (rounded up) is accepted and fits the budget.
  const TargetIndex t = build_target_index(m, fit, Mask(), o);
  EXPECT_LE(t.index.size(), o.max_pairs);
  EXPECT_GT(t.index.size(), o.max_pairs / 2);
}

TEST(BuildTargetIndex, EstimateCheckRefusesWhatTheBuildRefusesBeforeTessellating) {
  // ~2.5e7 pairs estimated at 2 mm against a budget of 2e5 (far over): the same refusal as the
  // build's, word for word. At the edge the refusal names, and at edge 0 (suggested), no refusal.
  const Mesh m = icosphere(0.05, 3);
  PairIndexOptions o;
  o.d_max = 0.2;
  o.max_pairs = 200000;
  auto message = [](const std::function<void()>& f) {
    try {
      f();
    } catch (const BudgetError& e) {
      return std::string(e.what());
    }
    return std::string("no BudgetError");
  };
  const std::string built = message([&] { build_target_index(m, 0.002, Mask(), o); });
  EXPECT_EQ(message([&] { check_pair_estimate(m, 0.002, Mask(), o); }), built);
  EXPECT_NE(built.find("gives about"), std::string::npos) << built;  // refused on the estimate
  std::smatch match;
  ASSERT_TRUE(std::regex_search(built, match, std::regex("a facet edge of ([0-9.e-]+) m fits"))) << built;
  EXPECT_NO_THROW(check_pair_estimate(m, std::stod(match[1]), Mask(), o));
  EXPECT_NO_THROW(check_pair_estimate(m, 0.0, Mask(), o));
  EXPECT_THROW(check_pair_estimate(m, -0.001, Mask(), o), std::invalid_argument);
  EXPECT_THROW(check_pair_estimate(m, 0.002, Mask::Constant(3, true), o), std::invalid_argument);
  o.max_pairs = 0;
  EXPECT_THROW(check_pair_estimate(m, 0.002, Mask(), o), std::invalid_argument);
}

// Thinning on a plane, where every pair has n_i.n_j = 1 and beta = 0: the pairs differ by their
// distance alone. With cells of 1 mm in d, each cell's count c is known by brute force; a stored
// pair's weight is ceil(c / cap) (1 when c <= cap), the stored pairs are a subset of all, and the
// same whatever the threads.
TEST(PairIndex, ThinningWeighsEachCellByItsBruteForceCount) {
  const int side = 36;
  Points p(side * side, 3), n(side * side, 3);
  for (int i = 0; i < side * side; ++i) {
    p.row(i) << 0.004 * (i % side), 0.004 * (i / side), 0.0;
    n.row(i) << 0, 0, 1;
  }
  const double d_max = 0.04, cap = 64;
  PairIndexOptions o;
  o.d_max = d_max;
  o.max_pairs_per_cell = 64;
  o.cell = Eigen::Vector3d(0.001, 0.5, 0.5);
  o.threads = 1;
  const PairIndex a(p, n, Mask(), o);
  o.threads = 2;
  const PairIndex b(p, n, Mask(), o);
  EXPECT_EQ(a.pairs(), b.pairs());
  EXPECT_EQ(a.max_pairs_per_cell(), 64u);
  EXPECT_TRUE(a.thin_cell().isApprox(o.cell));

  const PairSet all = brute_pairs(p, d_max);
  std::map<int, std::size_t> count;  // by 1 mm distance cell
  auto cell_of = [&](int i, int j) { return int(std::floor(double(float((p.row(i) - p.row(j)).norm())) / 0.001)); };
  for (const auto& [i, j] : all) ++count[cell_of(i, j)];
  EXPECT_EQ(a.pairs_found(), all.size());
  EXPECT_LT(a.size(), all.size() / 2);
  double weighted = 0.0, variance = 0.0;
  for (Eigen::Index k = 0; k < a.pairs().rows(); ++k) {
    const int i = a.pairs()(k, 0), j = a.pairs()(k, 1);
    ASSERT_TRUE(all.count({i, j}));
    const std::size_t c = count[cell_of(i, j)];
    const std::uint32_t want = c > cap ? std::uint32_t((c + 63) / 64) : 1u;
    EXPECT_EQ(a.weight(std::size_t(k)), want) << "pair " << i << ", " << j << " of a cell of " << c;
    weighted += a.weight(std::size_t(k));
  }
  for (const auto& [cell, c] : count) variance += double(c) * (c > cap ? double((c + 63) / 64) - 1.0 : 0.0);
  EXPECT_LE(std::abs(weighted - double(all.size())), 5.0 * std::sqrt(variance) + 1.0);
  EXPECT_THROW(a.weight(a.size()), std::out_of_range);

  PairIndexOptions bad = o;
  bad.cell = Eigen::Vector3d(0.001, 0.0, 0.5);
  EXPECT_THROW(PairIndex(p, n, Mask(), bad), std::invalid_argument);
}
