// Grasp quality (Ferrari-Canny epsilon) against hand computations and an independent brute-force
// enumeration of the wrench hull's facets (no qhull).
#include <pairgrasp/quality.hpp>
#include <pairgrasp/wrenches.hpp>

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

namespace {

namespace pg = pairgrasp;

struct Contacts {
  pg::Points points, normals;
};

/// m contacts on a sphere of radius `r` about the origin, normals radial, tilted by `scatter`.
Contacts sphere_grasp(std::mt19937& rng, int m, double r, double scatter) {
  std::normal_distribution<double> g;
  Contacts c{pg::Points(m, 3), pg::Points(m, 3)};
  for (int i = 0; i < m; ++i) {
    const Eigen::Vector3d d = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    c.points.row(i) = r * d.transpose();
    c.normals.row(i) = (d + scatter * Eigen::Vector3d(g(rng), g(rng), g(rng))).transpose();
  }
  return c;
}

/// The facets of conv(w) by enumerating every 6 wrenches: a hyperplane {x : u.x = 1} through 6 of
/// them with every other wrench on the origin's side is a facet at distance 1/|u|; `det` is the
/// determinant of its 6 wrenches (for simplicial facets the hull is the union of the cones from the
/// origin over them). Valid only when the origin is strictly inside.
struct BruteFacet {
  Eigen::Matrix<double, 6, 1> u;
  double det;
};

std::vector<BruteFacet> brute_force_facets(const pg::Wrenches& w) {
  const int m = static_cast<int>(w.rows());
  std::vector<BruteFacet> facets;
  std::vector<bool> pick(m, false);
  std::fill(pick.begin(), pick.begin() + 6, true);
  do {
    Eigen::Matrix<double, 6, 6> a;
    for (int i = 0, k = 0; i < m; ++i)
      if (pick[i]) a.row(k++) = w.row(i);
    const double det = a.determinant();
    if (std::abs(det) <= 1e-12) continue;
    const Eigen::Matrix<double, 6, 1> u = a.partialPivLu().solve(Eigen::Matrix<double, 6, 1>::Ones());
    if ((w * u).maxCoeff() > 1.0 + 1e-9) continue;
    facets.push_back({u, det});
  } while (std::prev_permutation(pick.begin(), pick.end()));
  return facets;
}

/// (epsilon, volume) of conv(w) from brute_force_facets().
std::pair<double, double> brute_force_hull(const pg::Wrenches& w) {
  double max_u = 0.0, volume = 0.0;
  for (const BruteFacet& f : brute_force_facets(w)) {
    max_u = std::max(max_u, f.u.norm());
    volume += std::abs(f.det) / 720.0;
  }
  return {1.0 / max_u, volume};
}

/// The largest t with (t d, 0) in conv(w) from brute_force_facets(): each facet the ray meets
/// (u.(d, 0) > 0) bounds t by 1 / u.(d, 0), and the least bound is where the ray leaves the hull.
double brute_force_ray_exit(const pg::Wrenches& w, const Eigen::Vector3d& d) {
  double exit = std::numeric_limits<double>::infinity();
  for (const BruteFacet& f : brute_force_facets(w)) {
    const double along = f.u.head<3>().dot(d);
    if (along > 0.0) exit = std::min(exit, 1.0 / along);
  }
  return exit;
}

pg::QualityOptions options(double mu, int edges, int max_hull_wrenches = 320) {
  pg::QualityOptions o;
  o.contact.mu = mu;
  o.contact.edges = edges;
  o.max_hull_wrenches = max_hull_wrenches;
  return o;
}

/// A random rotation (columns orthonormal, det +1).
Eigen::Matrix3d random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> g;
  return Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
}

TEST(Quality, EpsilonAndVolumeMatchBruteForceFacetEnumeration) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> mu_dist(0.3, 1.2);
  int checked = 0, tried = 0;
  while (checked < 6 && tried < 200) {
    ++tried;
    const Contacts c = sphere_grasp(rng, 4 + tried % 2, 0.03, 0.2);
    const double mu = mu_dist(rng);
    const pg::GraspQuality q = pg::grasp_quality(c.points, c.normals, Eigen::Vector3d::Zero(), 0.03, options(mu, 3));
    if (!q.force_closure) continue;
    const auto [eps, volume] =
        brute_force_hull(pg::wrench_matrix(c.points, c.normals, Eigen::Vector3d::Zero(), 0.03, mu, 3));
    EXPECT_NEAR(q.epsilon, eps, 1e-9 * eps);
    EXPECT_NEAR(q.volume, volume, 1e-9 * volume);
    EXPECT_TRUE(q.volume_exact && q.epsilon_computed && q.reason.empty() && q.rank == 6);
    ++checked;
  }
  EXPECT_EQ(checked, 6);
}

TEST(Quality, TwoAntipodalSoftContactsMatchTheClosedForm) {
  // Contacts at c +- r x, inward normals -+x, 4 pyramid edges, torsion radius g: the 12 wrenches
  // are (-1, k e_A), (-1, k e_B), (-1, +-g/r e_5), (1, k e_C), (1, k e_D), (1, +-g/r e_5) (each
  // +-) in an orthonormal frame, k = mu sqrt(2). The facets with u_fx = 0 touch one wrench of each
  // pair, so epsilon = 1 / sqrt(2/mu^2 + r^2/g^2) when (g/r)^2 (1 + 2/mu^2) <= 1.
  std::mt19937 rng(5);
  for (const auto& [mu, r, g] : {std::tuple{0.5, 0.05, 0.01}, std::tuple{1.0, 0.02, 0.01}, std::tuple{0.3, 0.1, 0.02}}) {
    ASSERT_LE((g / r) * (g / r) * (1 + 2 / (mu * mu)), 1.0);
    const double expected = 1.0 / std::sqrt(2 / (mu * mu) + r * r / (g * g));
    for (int trial = 0; trial < 3; ++trial) {
      const Eigen::Matrix3d rot = random_rotation(rng);
      const Eigen::Vector3d x = rot.col(0), t(0.1 * trial, -0.2, 0.05);
      pg::Points p(2, 3), n(2, 3);
      p << (t + r * x).transpose(), (t - r * x).transpose();
      n << x.transpose(), -x.transpose();
      pg::QualityOptions o = options(mu, 4);
      o.contact.soft = true;
      o.contact.torsion = g;
      const pg::GraspQuality q = pg::grasp_quality(p, n, t, r, o);
      ASSERT_TRUE(q.force_closure) << q.reason;
      EXPECT_EQ(q.rank, 6);
      EXPECT_NEAR(q.epsilon, expected, 1e-9 * expected);
      EXPECT_GE(q.epsilon_bound, q.epsilon * (1 - 1e-12));
      // Point contacts: no moment about the contact line, rank 5, an ordinary non-closure.
      const pg::GraspQuality point = pg::grasp_quality(p, n, t, r, options(mu, 64));
      EXPECT_FALSE(point.force_closure);
      EXPECT_EQ(point.epsilon, 0.0);
      EXPECT_EQ(point.rank, 5);
      EXPECT_NE(point.reason.find("rank"), std::string::npos);
    }
  }
}

TEST(Quality, CubeFaceCentres) {
  // Six contacts at the face centres of a cube of half side a, r = sqrt(3) a. Along the pure-torque
  // direction u = (0, d), d = (1,1,1)/sqrt(3), every wrench has u.w = mu (a/r) d.(e_i x t) <=
  // mu (a/r) |d x e_i| = mu (a/r) sqrt(2/3), so epsilon <= mu sqrt(2)/3 for any pyramid.
  const double a = 0.02, r = std::sqrt(3.0) * a;
  pg::Points p(6, 3), n(6, 3);
  for (int i = 0; i < 3; ++i) {
    p.row(i) = a * Eigen::Vector3d::Unit(i).transpose();
    p.row(i + 3) = -a * Eigen::Vector3d::Unit(i).transpose();
  }
  n = p / a;
  for (const double mu : {0.2, 0.5, 1.0}) {
    for (const int edges : {4, 8, 16}) {
      const pg::GraspQuality q = pg::grasp_quality(p, n, Eigen::Vector3d::Zero(), r, options(mu, edges));
      ASSERT_TRUE(q.force_closure) << q.reason;
      EXPECT_GT(q.epsilon, 0.0);
      EXPECT_LE(q.epsilon, mu * std::sqrt(2.0) / 3 * (1 + 1e-12));
      EXPECT_EQ(q.n_contacts, 6);
      EXPECT_EQ(q.n_wrenches, 6 * edges);
    }
  }
  // Frictionless: forces along the three axes only and no torque at all.
  const pg::GraspQuality q = pg::grasp_quality(p, n, Eigen::Vector3d::Zero(), r, options(0.0, 8));
  EXPECT_FALSE(q.force_closure);
  EXPECT_EQ(q.epsilon, 0.0);
  EXPECT_EQ(q.rank, 3);
  EXPECT_TRUE(q.volume_exact);
}

TEST(Quality, ContactsOnOneFaceAndNoContactsAreNotForceClosure) {
  pg::Points p(5, 3), n(5, 3);
  for (int i = 0; i < 5; ++i) {
    p.row(i) << 0.05, 0.01 * i - 0.02, 0.003 * i * i - 0.01;
    n.row(i) << 1.0, 0.0, 0.0;
  }
  const pg::GraspQuality q = pg::grasp_quality(p, n, Eigen::Vector3d::Zero(), 0.07, options(0.8, 12));
  EXPECT_FALSE(q.force_closure);
  EXPECT_EQ(q.epsilon, 0.0);
  EXPECT_FALSE(q.reason.empty());
  const pg::GraspQuality none = pg::grasp_quality(pg::Points(0, 3), pg::Points(0, 3), Eigen::Vector3d::Zero(), 0.07);
  EXPECT_FALSE(none.force_closure);
  EXPECT_EQ(none.n_contacts, 0);
  EXPECT_EQ(none.reason, "no contacts");
}

TEST(Quality, UpperBoundIsNeverBelowEpsilon) {
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> mu_dist(0.1, 1.5);
  int fc = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const Contacts c = sphere_grasp(rng, 3 + trial % 8, 0.04, 0.5);
    pg::QualityOptions o = options(mu_dist(rng), 3 + trial % 6);
    o.contact.soft = trial % 3 == 0;
    o.contact.torsion = 0.004;
    const pg::GraspQuality q = pg::grasp_quality(c.points, c.normals, Eigen::Vector3d::Zero(), 0.04, o);
    const pg::Wrenches w = pg::wrench_matrix(c.points, c.normals, Eigen::Vector3d::Zero(), 0.04, o.contact);
    const double bound = pg::epsilon_upper_bound(w);
    EXPECT_GE(bound, q.epsilon * (1 - 1e-12)) << trial;
    // never above the smallest singular value of the wrench matrix
    EXPECT_LE(bound, Eigen::JacobiSVD<Eigen::MatrixXd>(Eigen::MatrixXd(w)).singularValues()(5) * (1 + 1e-12));
    if (q.rank == 6) {
      EXPECT_GE(q.epsilon_bound, q.epsilon * (1 - 1e-12)) << trial;
    }
    fc += q.force_closure;
  }
  EXPECT_GE(fc, 10);
  EXPECT_EQ(pg::epsilon_upper_bound(pg::Wrenches(0, 6)), 0.0);
}

TEST(Quality, MinEpsilonSkipsOnlyGraspsThatCannotReachIt) {
  std::mt19937 rng(22);
  int checked = 0;
  for (int trial = 0; trial < 30; ++trial) {
    const Contacts c = sphere_grasp(rng, 6, 0.04, 0.3);
    const pg::GraspQuality full = pg::grasp_quality(c.points, c.normals, Eigen::Vector3d::Zero(), 0.04, options(0.6, 8));
    if (!full.force_closure) continue;
    ++checked;
    pg::QualityOptions o = options(0.6, 8);
    o.min_epsilon = full.epsilon;  // reachable: the hull is built, the result unchanged
    const pg::GraspQuality kept = pg::grasp_quality(c.points, c.normals, Eigen::Vector3d::Zero(), 0.04, o);
    EXPECT_TRUE(kept.epsilon_computed && kept.force_closure);
    EXPECT_EQ(kept.epsilon, full.epsilon);
    EXPECT_EQ(kept.volume, full.volume);
    o.min_epsilon = full.epsilon_bound * 1.001;  // above the bound: skipped, and out of reach indeed
    const pg::GraspQuality skipped = pg::grasp_quality(c.points, c.normals, Eigen::Vector3d::Zero(), 0.04, o);
    EXPECT_FALSE(skipped.epsilon_computed);
    EXPECT_LT(full.epsilon, o.min_epsilon);
    // Force closure is still decided, with a lower bound of epsilon.
    EXPECT_TRUE(skipped.force_closure);
    EXPECT_GT(skipped.epsilon, 0.0);
    EXPECT_LE(skipped.epsilon, full.epsilon * (1 + 1e-9));
    EXPECT_LE(skipped.epsilon_bound, o.min_epsilon);
    EXPECT_EQ(skipped.volume, 0.0);
    EXPECT_FALSE(skipped.volume_exact);
    EXPECT_EQ(skipped.reason, "");
  }
  EXPECT_GE(checked, 5);
}

// Above max_hull_wrenches, the active set's hulls bound epsilon from above through their facets as
// the set grows, and stop once that bound falls below min_epsilon: every skip is of a grasp whose
// full epsilon is below the threshold, a skipped grasp reported force-closure is force-closure with
// at least the reported epsilon, and those facets skip grasps that the hull-free bounds cannot
// (the same grasps with the whole hull built at once, max_hull_wrenches 320, are not skipped).
TEST(Quality, MinEpsilonActiveSetBoundIsSound) {
  std::mt19937 rng(23);
  int skipped_by_facets = 0, proven = 0, cases = 0;
  for (int trial = 0; trial < 32; ++trial) {
    const Contacts c = sphere_grasp(rng, 9 + trial % 4, 0.04, 0.3);  // 72..96 wrenches
    const pg::GraspQuality full = pg::grasp_quality(c.points, c.normals, Eigen::Vector3d::Zero(), 0.04, options(0.6, 8));
    if (full.rank < 6) continue;
    for (double f : {0.3, 0.5, 0.7, 0.9}) {
      pg::QualityOptions o = options(0.6, 8, 64), at_once = options(0.6, 8, 320);
      o.min_epsilon = at_once.min_epsilon = f * full.epsilon_bound;
      const pg::GraspQuality q = pg::grasp_quality(c.points, c.normals, Eigen::Vector3d::Zero(), 0.04, o);
      const pg::GraspQuality hull_free = pg::grasp_quality(c.points, c.normals, Eigen::Vector3d::Zero(), 0.04, at_once);
      ++cases;
      if (q.epsilon_computed) {
        EXPECT_NEAR(q.epsilon, full.epsilon, 1e-9 * full.epsilon_bound) << trial;
        EXPECT_EQ(q.force_closure, full.force_closure) << trial;
        EXPECT_TRUE(hull_free.epsilon_computed) << trial;  // the facets skip at least what the bounds do
        continue;
      }
      EXPECT_LT(full.epsilon, o.min_epsilon) << trial;  // never skips a grasp that reaches it
      EXPECT_GE(q.epsilon_bound, full.epsilon * (1 - 1e-12)) << trial;
      EXPECT_LT(q.epsilon_bound, o.min_epsilon) << trial;
      skipped_by_facets += hull_free.epsilon_computed;
      EXPECT_EQ(q.force_closure, full.force_closure) << trial;  // decided even when skipped
      if (q.force_closure) {
        ++proven;
        EXPECT_LE(q.epsilon, full.epsilon * (1 + 1e-9)) << trial;
        EXPECT_GT(q.epsilon, 0.0);
      } else {
        EXPECT_EQ(q.epsilon, 0.0);
      }
    }
  }
  std::printf("%d cases: %d skipped by the active set's facets, %d skipped grasps proven force-closure\n", cases,
              skipped_by_facets, proven);
  EXPECT_GT(cases, 100);
  EXPECT_GE(skipped_by_facets, 8);
  EXPECT_GT(proven, 0);
}

// A skip decides force closure without the full hull (Wolfe's minimum-norm point, checked on its
// certificate): on grasps of every kind, closed or not, near the boundary or deep inside, the
// verdict equals the full hull's, and a closed grasp's lower bound never exceeds its epsilon.
TEST(Quality, SkippedGraspsKeepTheHullsForceClosureVerdict) {
  std::mt19937 rng(31);
  int closed = 0, open = 0;
  for (int trial = 0; trial < 60; ++trial) {
    Contacts c = sphere_grasp(rng, 3 + trial % 9, 0.04, 0.05 + 0.1 * (trial % 5));
    if (trial % 3 == 0)  // every contact on one hemisphere: mostly not force-closure
      for (Eigen::Index i = 0; i < c.points.rows(); ++i) {
        c.points(i, 2) = std::abs(c.points(i, 2));
        c.normals(i, 2) = std::abs(c.normals(i, 2));
      }
    const pg::GraspQuality full = pg::grasp_quality(c.points, c.normals, Eigen::Vector3d::Zero(), 0.04, options(0.5, 8));
    if (full.rank < 6) continue;
    for (bool open_volume : {true, false}) {
      pg::QualityOptions o = options(0.5, 8);
      o.open_volume = open_volume;
      o.min_epsilon = 1e6;  // every hull skipped
      const pg::GraspQuality q = pg::grasp_quality(c.points, c.normals, Eigen::Vector3d::Zero(), 0.04, o);
      EXPECT_EQ(q.force_closure, full.force_closure) << trial;
      if (full.force_closure) {
        EXPECT_GT(q.epsilon, 0.0) << trial;
        EXPECT_LE(q.epsilon, full.epsilon * (1 + 1e-9)) << trial;
      } else {
        EXPECT_EQ(q.epsilon, 0.0) << trial;
      }
    }
    (full.force_closure ? closed : open) += 1;
  }
  EXPECT_GT(closed, 10);
  EXPECT_GT(open, 10);
}

// Joggled input: the same force closure, and epsilon within 1e-9 relative of the exact options'.
TEST(Quality, JoggledHullEpsilonEqualsTheExactOne) {
  std::mt19937 rng(37);
  int closed = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const Contacts c = sphere_grasp(rng, 6 + trial % 8, 0.04, 0.3);
    const pg::GraspQuality exact = pg::grasp_quality(c.points, c.normals, Eigen::Vector3d::Zero(), 0.04, options(0.5, 8));
    pg::QualityOptions o = options(0.5, 8);
    o.joggle = true;
    const pg::GraspQuality joggled = pg::grasp_quality(c.points, c.normals, Eigen::Vector3d::Zero(), 0.04, o);
    EXPECT_EQ(joggled.force_closure, exact.force_closure) << trial;
    EXPECT_NEAR(joggled.epsilon, exact.epsilon, 1e-9 * std::max(exact.epsilon, 1e-3)) << trial;
    closed += exact.force_closure;
  }
  EXPECT_GT(closed, 5);
}

TEST(Quality, ActiveSetEpsilonEqualsTheFullHull) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 6; ++trial) {
    Contacts c = sphere_grasp(rng, 28, 0.04, 0.1);
    if (trial >= 3)
      for (int i = 0; i < 28; ++i) c.normals(i, 2) = std::abs(c.normals(i, 2)) + 1.5;  // a cone of normals
    const Eigen::Vector3d o = Eigen::Vector3d::Zero();
    const pg::GraspQuality full = pg::grasp_quality(c.points, c.normals, o, 0.05, options(0.5, 8, 100000));
    const pg::GraspQuality active = pg::grasp_quality(c.points, c.normals, o, 0.05, options(0.5, 8, 7));
    EXPECT_TRUE(full.volume_exact);
    EXPECT_EQ(active.force_closure, full.force_closure) << trial;
    EXPECT_NEAR(active.epsilon, full.epsilon, 1e-9 * full.epsilon + 1e-12) << trial;
    EXPECT_LE(active.volume, full.volume * (1 + 1e-9));
  }
}

TEST(Quality, WithoutOpenVolumeOnlyNonClosureChanges) {
  std::mt19937 rng(100);
  int outside = 0;
  for (int trial = 0; trial < 16; ++trial) {
    Contacts c = sphere_grasp(rng, 10, 0.04, 0.1);
    if (trial % 2)
      for (int i = 0; i < 10; ++i) c.normals(i, 2) = std::abs(c.normals(i, 2)) + 1.0;
    pg::QualityOptions o = options(0.5, 8);
    const pg::GraspQuality full = pg::grasp_quality(c.points, c.normals, Eigen::Vector3d::Zero(), 0.05, o);
    o.open_volume = false;
    const pg::GraspQuality fast = pg::grasp_quality(c.points, c.normals, Eigen::Vector3d::Zero(), 0.05, o);
    EXPECT_EQ(fast.force_closure, full.force_closure);
    EXPECT_EQ(fast.epsilon, full.epsilon);
    if (full.force_closure) {
      EXPECT_EQ(fast.volume, full.volume);
    } else if (!fast.volume_exact) {
      EXPECT_EQ(fast.volume, 0.0);
      outside += fast.reason == "the origin is outside the wrench hull";
    }
  }
  EXPECT_GT(outside, 0);
}

TEST(Quality, ThreadsGiveTheSerialAnswers) {
  std::mt19937 rng(31);
  std::vector<Contacts> grasps;
  for (int i = 0; i < 24; ++i) grasps.push_back(sphere_grasp(rng, 5 + i % 20, 0.04, 0.3));
  auto run = [&](std::size_t i) {
    return pg::grasp_quality(grasps[i].points, grasps[i].normals, Eigen::Vector3d::Zero(), 0.04,
                             options(0.5, 8, i % 2 ? 7 : 320));
  };
  std::vector<pg::GraspQuality> serial, parallel(grasps.size());
  for (std::size_t i = 0; i < grasps.size(); ++i) serial.push_back(run(i));
  std::vector<std::thread> pool;
  for (int t = 0; t < 4; ++t)
    pool.emplace_back([&, t] {
      for (std::size_t i = t; i < grasps.size(); i += 4) parallel[i] = run(i);
    });
  for (auto& th : pool) th.join();
  for (std::size_t i = 0; i < grasps.size(); ++i) {
    EXPECT_EQ(parallel[i].epsilon, serial[i].epsilon) << i;
    EXPECT_EQ(parallel[i].volume, serial[i].volume) << i;
    EXPECT_EQ(parallel[i].reason, serial[i].reason) << i;
  }
}

TEST(Quality, BadInputThrowsNamingTheArgument) {
  pg::Points p(2, 3), n(2, 3);
  p << 0.01, 0, 0, -0.01, 0, 0;
  n << 1, 0, 0, -1, 0, 0;
  const Eigen::Vector3d c = Eigen::Vector3d::Zero();
  auto message = [&](auto call) -> std::string {
    try {
      call();
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "no exception";
  };
  auto starts = [](const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; };
  pg::Points bad = p;
  bad(0, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(starts(message([&] { pg::grasp_quality(bad, n, c, 0.01); }), "points:"));
  EXPECT_TRUE(starts(message([&] { pg::grasp_quality(p, bad, c, 0.01); }), "normals:"));
  EXPECT_TRUE(starts(message([&] { pg::grasp_quality(p, pg::Points::Zero(2, 3), c, 0.01); }), "normals:"));
  EXPECT_TRUE(starts(message([&] { pg::grasp_quality(p, n.topRows(1), c, 0.01); }), "normals:"));
  EXPECT_TRUE(starts(message([&] { pg::grasp_quality(p, n, Eigen::Vector3d(0, NAN, 0), 0.01); }), "center:"));
  EXPECT_TRUE(starts(message([&] { pg::grasp_quality(p, n, c, 0.0); }), "radius:"));
  EXPECT_TRUE(starts(message([&] { pg::grasp_quality(p, n, c, 0.01, options(-0.1, 8)); }), "mu:"));
  EXPECT_TRUE(starts(message([&] { pg::grasp_quality(p, n, c, 0.01, options(0.5, 2)); }), "edges:"));
  EXPECT_TRUE(starts(message([&] { pg::grasp_quality(p, n, c, 0.01, options(0.5, 8, 6)); }), "max_hull_wrenches:"));
  pg::QualityOptions o;
  o.contact.soft = true;
  EXPECT_TRUE(starts(message([&] { pg::grasp_quality(p, n, c, 0.01, o); }), "torsion:"));
  o.contact.torsion = -1.0;
  EXPECT_TRUE(starts(message([&] { pg::grasp_quality(p, n, c, 0.01, o); }), "torsion:"));
  o.contact.torsion = 0.01;
  o.contact.soft_rings = -1;
  EXPECT_TRUE(starts(message([&] { pg::grasp_quality(p, n, c, 0.01, o); }), "soft_rings:"));
  o = pg::QualityOptions();
  o.min_epsilon = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(starts(message([&] { pg::grasp_quality(p, n, c, 0.01, o); }), "min_epsilon:"));
  pg::Wrenches w = pg::Wrenches::Ones(7, 6);
  w(3, 3) = NAN;
  EXPECT_TRUE(starts(message([&] { pg::epsilon_upper_bound(w); }), "wrenches:"));
}

}  // namespace

TEST(Quality, ForceResistanceMatchesBruteForceFacetEnumeration) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> mu_dist(0.3, 1.2);
  std::normal_distribution<double> g;
  int checked = 0, tried = 0;
  while (checked < 6 && tried < 200) {
    ++tried;
    const Contacts c = sphere_grasp(rng, 4 + tried % 2, 0.03, 0.2);
    const Eigen::Vector3d center(0.004 * g(rng), 0.004 * g(rng), 0.004 * g(rng));
    const double mu = mu_dist(rng);
    const pg::GraspQuality q = pg::grasp_quality(c.points, c.normals, center, 0.03, options(mu, 3));
    if (!q.force_closure) continue;
    pg::Points dirs(9, 3);
    dirs.topRows(6) = pg::load_directions();
    for (int k = 6; k < 9; ++k) dirs.row(k) = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized().transpose();
    pg::ContactModel model;
    model.mu = mu;
    model.edges = 3;
    const Eigen::VectorXd got = pg::force_resistance(c.points, c.normals, center, 0.03, dirs, model);
    const pg::Wrenches w = pg::wrench_matrix(c.points, c.normals, center, 0.03, mu, 3);
    for (int k = 0; k < 9; ++k) {
      const double want = brute_force_ray_exit(w, dirs.row(k).transpose());
      EXPECT_NEAR(got[k], want, 1e-6 * want) << tried << " direction " << k;
      EXPECT_GE(got[k], q.epsilon * (1 - 1e-9));
    }
    EXPECT_DOUBLE_EQ(pg::load_resistance(c.points, c.normals, center, 0.03, model), got.head(6).minCoeff());
    ++checked;
  }
  EXPECT_EQ(checked, 6);
}

TEST(Quality, ForceResistanceOfTheCubeFaceCentresIsOneAlongEveryAxis) {
  // Six contacts at the face centres of a cube. Along +x only the contact on the -x face pushes with
  // a force component above mu < 1 (each of its pyramid edges has f_x = 1 per unit normal force),
  // and the mean of its edges is the pure force (1, 0, 0) with no torque about the centre: t = 1.
  const double a = 0.02, r = std::sqrt(3.0) * a;
  pg::Points p(6, 3);
  for (int i = 0; i < 3; ++i) {
    p.row(i) = a * Eigen::Vector3d::Unit(i).transpose();
    p.row(i + 3) = -a * Eigen::Vector3d::Unit(i).transpose();
  }
  const pg::Points n = p / a;
  for (const double mu : {0.2, 0.5, 0.9}) {
    for (const int edges : {4, 8}) {
      pg::ContactModel model;
      model.mu = mu;
      model.edges = edges;
      const Eigen::VectorXd t = pg::force_resistance(p, n, Eigen::Vector3d::Zero(), r, pg::load_directions(), model);
      for (int k = 0; k < 6; ++k) EXPECT_NEAR(t[k], 1.0, 1e-9) << mu << " " << edges << " " << k;
    }
  }
}

TEST(Quality, ForceResistanceIsZeroWithoutForceClosureAndRefusesBadDirections) {
  pg::Points p(5, 3), n(5, 3);
  for (int i = 0; i < 5; ++i) {
    p.row(i) << 0.05, 0.01 * i - 0.02, 0.003 * i * i - 0.01;
    n.row(i) << 1.0, 0.0, 0.0;
  }
  EXPECT_TRUE(pg::force_resistance(p, n, Eigen::Vector3d::Zero(), 0.07, pg::load_directions()).isZero(0.0));
  EXPECT_EQ(pg::load_resistance(pg::Points(0, 3), pg::Points(0, 3), Eigen::Vector3d::Zero(), 0.07), 0.0);
  pg::Points bad = pg::load_directions();
  bad(2, 0) = 0.5;
  try {
    pg::force_resistance(p, n, Eigen::Vector3d::Zero(), 0.07, bad);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("directions: row 2"), std::string::npos) << e.what();
  }
  bad(2, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(pg::force_resistance(p, n, Eigen::Vector3d::Zero(), 0.07, bad), std::invalid_argument);
  EXPECT_THROW(pg::force_resistance(p, n.topRows(4), Eigen::Vector3d::Zero(), 0.07, pg::load_directions()),
               std::invalid_argument);
}
