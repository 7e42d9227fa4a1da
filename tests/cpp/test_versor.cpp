// The six-pairing versor solver against known rigid transforms.
#include <pairgrasp/versor.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

using namespace pairgrasp;
using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Rigid {
  Matrix3d R;
  Vector3d t;
};

Matrix3d random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  Quaterniond q(g(rng), g(rng), g(rng), g(rng));
  q.normalize();
  return q.toRotationMatrix();
}

Vector3d random_unit(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  Vector3d v(g(rng), g(rng), g(rng));
  return v.normalized();
}

Vector3d random_vec(std::mt19937_64& rng, double s) {
  std::normal_distribution<double> g(0.0, s);
  return Vector3d(g(rng), g(rng), g(rng));
}

// A gripper pair and the target pair it becomes under T (target normals = -R.gripper normals).
struct Pair {
  Vector3d gp0, gp1, gn0, gn1, tp0, tp1, tn0, tn1;
};

Pair apply(const Rigid& T, const Vector3d& gp0, const Vector3d& gp1, const Vector3d& gn0, const Vector3d& gn1) {
  return {gp0, gp1, gn0, gn1, T.R * gp0 + T.t, T.R * gp1 + T.t, -(T.R * gn0), -(T.R * gn1)};
}

PairPoseResult solve(const Pair& p, const PairPoseOptions& o = {}) {
  return solve_pair_pose(p.gp0, p.gp1, p.gn0, p.gn1, p.tp0, p.tp1, p.tn0, p.tn1, o);
}

double rot_err(const Matrix3d& a, const Matrix3d& b) { return (a - b).cwiseAbs().maxCoeff(); }

// Angle (rad) between rotations, computed from the matrices (independent of the quaternions).
double rot_angle(const Matrix3d& a, const Matrix3d& b) {
  const double c = std::clamp(((a.transpose() * b).trace() - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c);
}

// Largest deviation when the candidate maps the gripper pair onto the target pair in its order.
double map_err(const PairPoseCandidate& c, const Pair& p) {
  const Vector3d& t0 = c.order == 0 ? p.tp0 : p.tp1;
  const Vector3d& t1 = c.order == 0 ? p.tp1 : p.tp0;
  const Vector3d& n0 = c.order == 0 ? p.tn0 : p.tn1;
  const Vector3d& n1 = c.order == 0 ? p.tn1 : p.tn0;
  double e = (c.rotation * p.gp0 + c.translation - t0).norm();
  e = std::max(e, (c.rotation * p.gp1 + c.translation - t1).norm());
  e = std::max(e, (-(c.rotation * p.gn0) - n0).norm());
  e = std::max(e, (-(c.rotation * p.gn1) - n1).norm());
  return e;
}

void expect_valid(const PairPoseResult& r) {
  for (const auto& c : r.candidates) {
    ASSERT_TRUE(c.rotation.allFinite());
    ASSERT_TRUE(c.translation.allFinite());
    ASSERT_TRUE(std::isfinite(c.angle) && c.axis.allFinite() && std::isfinite(c.residual));
    EXPECT_LT((c.rotation.transpose() * c.rotation - Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_NEAR(c.rotation.determinant(), 1.0, 1e-12);
    EXPECT_GE(c.agreement, 1);
    EXPECT_LE(c.agreement, 3);
    EXPECT_TRUE(c.order == 0 || c.order == 1);
  }
  if (r.status == PairPoseStatus::Ok) {
    EXPECT_FALSE(r.candidates.empty());
  } else {
    EXPECT_TRUE(r.candidates.empty());
  }
}

}  // namespace

TEST(Versor, RandomRigidTransformsRecoveredExactly) {
  std::mt19937_64 rng(1);
  double worst_r = 0, worst_t = 0;
  int wrong_full = 0;
  for (int trial = 0; trial < 500; ++trial) {
    const Rigid T{random_rotation(rng), random_vec(rng, 0.1)};
    const Pair p = apply(T, random_vec(rng, 0.05), random_vec(rng, 0.05), random_unit(rng), random_unit(rng));
    const auto r = solve(p);
    ASSERT_EQ(r.status, PairPoseStatus::Ok) << "trial " << trial;
    expect_valid(r);
    const auto& best = r.candidates.front();
    worst_r = std::max(worst_r, rot_err(best.rotation, T.R));
    worst_t = std::max(worst_t, (best.translation - T.t).norm());
    EXPECT_EQ(best.agreement, 3) << "trial " << trial;
    EXPECT_EQ(best.order, 0) << "trial " << trial;
    // The wrong point order reproduces at most one meeting, unless the pair is nearly symmetric
    // (a half turn about (a0 + a1) swaps the points: u.(a0 + a1) ~ 0 with a = -n).
    const Vector3d u = (p.gp1 - p.gp0).normalized();
    const double asym = std::abs(u.dot(p.gn0 + p.gn1));
    for (const auto& c : r.candidates)
      if (c.order == 1 && c.agreement > 1) {
        ++wrong_full;
        EXPECT_LT(asym, 3 * PairPoseOptions().angle_tolerance) << "trial " << trial;
        EXPECT_GT(c.residual, 1e-6);
      }
  }
  EXPECT_LT(wrong_full, 50);
  EXPECT_LT(worst_r, 1e-9);
  EXPECT_LT(worst_t, 1e-9);
}

TEST(Versor, SwappedTargetOrderIsRecoveredAsOrderOne) {
  std::mt19937_64 rng(2);
  for (int trial = 0; trial < 200; ++trial) {
    const Rigid T{random_rotation(rng), random_vec(rng, 0.1)};
    Pair p = apply(T, random_vec(rng, 0.05), random_vec(rng, 0.05), random_unit(rng), random_unit(rng));
    std::swap(p.tp0, p.tp1);
    std::swap(p.tn0, p.tn1);
    const auto r = solve(p);
    ASSERT_EQ(r.status, PairPoseStatus::Ok);
    EXPECT_EQ(r.candidates.front().order, 1);
    EXPECT_LT(rot_err(r.candidates.front().rotation, T.R), 1e-9);
    EXPECT_LT((r.candidates.front().translation - T.t).norm(), 1e-9);
  }
}

TEST(Versor, GripperNormalsAreFlipped) {
  // Target normals equal to +R.n (not flipped) are not a contact: no full agreement. (Pairs with
  // both normals across the line, or equal angles to it, are excluded: a half turn about the line
  // or about n0 - n1 reverses both normals there, so flipped and unflipped both fit.)
  std::mt19937_64 rng(3);
  int full = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const Rigid T{random_rotation(rng), random_vec(rng, 0.1)};
    Vector3d g0, g1, n0, n1;
    do {
      g0 = random_vec(rng, 0.05);
      g1 = random_vec(rng, 0.05);
      n0 = random_unit(rng);
      n1 = random_unit(rng);
    } while (std::abs((g1 - g0).normalized().dot(n0)) < 0.3 || std::abs((g1 - g0).normalized().dot(n0 - n1)) < 0.3);
    Pair p = apply(T, g0, g1, n0, n1);
    EXPECT_EQ(solve(p).candidates.front().agreement, 3);
    p.tn0 = -p.tn0;
    p.tn1 = -p.tn1;
    const auto r = solve(p);
    expect_valid(r);
    for (const auto& c : r.candidates) full += c.agreement == 3;
  }
  EXPECT_EQ(full, 0);
}

TEST(Versor, CanonicalVersorMatchesRotation) {
  std::mt19937_64 rng(4);
  for (int trial = 0; trial < 200; ++trial) {
    const Rigid T{random_rotation(rng), random_vec(rng, 0.1)};
    const Pair p = apply(T, random_vec(rng, 0.05), random_vec(rng, 0.05), random_unit(rng), random_unit(rng));
    const auto r = solve(p);
    const auto& c = r.candidates.front();
    const bool upper = c.axis.z() > 0 || (c.axis.z() == 0 && (c.axis.y() > 0 || (c.axis.y() == 0 && c.axis.x() > 0)));
    EXPECT_TRUE(upper);
    EXPECT_GT(c.angle, -kPi);
    EXPECT_LE(c.angle, kPi);
    EXPECT_NEAR(c.axis.norm(), 1.0, 1e-12);
    // Rodrigues' formula, written out here independently of the solver.
    const Vector3d k = c.axis;
    Matrix3d K;
    K << 0, -k.z(), k.y(), k.z(), 0, -k.x(), -k.y(), k.x(), 0;
    const Matrix3d Rr = Matrix3d::Identity() + std::sin(c.angle) * K + (1 - std::cos(c.angle)) * K * K;
    EXPECT_LT(rot_err(Rr, c.rotation), 1e-12);
    EXPECT_LT(rot_err(c.versor.toRotationMatrix(), c.rotation), 1e-12);
  }
  double a = -kPi;
  Vector3d m(0, 0, -1);
  canonicalize_versor(a, m);
  EXPECT_EQ(a, kPi);
  EXPECT_EQ(m, Vector3d(0, 0, 1));
  a = -kPi;
  m = Vector3d(1, 0, 0);
  canonicalize_versor(a, m);  // (-pi, m) is written (pi, m)
  EXPECT_EQ(a, kPi);
  EXPECT_EQ(m, Vector3d(1, 0, 0));
  a = 0.3;
  m = Vector3d(0, -1, 0);
  canonicalize_versor(a, m);
  EXPECT_DOUBLE_EQ(a, -0.3);
  EXPECT_EQ(m, Vector3d(0, 1, 0));
}

TEST(Versor, ErrorGrowsLinearlyWithNoise) {
  // Perturb the target normals and points; the rotation error over sigma stays bounded and
  // about constant from 1e-6 to 1e-2 rad (no cliff). Nearly symmetric pairs (u.(n0 + n1) ~ 0,
  // where the swapped order fits as well within the noise) are left out: their point order is
  // not determined by the pair itself.
  const std::vector<double> sigmas{1e-6, 1e-5, 1e-4, 1e-3, 3e-3, 1e-2};
  std::vector<double> p95;
  for (double s : sigmas) {
    std::mt19937_64 rng(5);
    std::vector<double> ratio;
    PairPoseOptions o;
    o.angle_tolerance = std::max(0.05, 10 * s);
    for (int trial = 0; trial < 300; ++trial) {
      const Rigid T{random_rotation(rng), random_vec(rng, 0.1)};
      // Well-conditioned pairs: normals at least 30 degrees from each other and the line.
      Vector3d g0, g1, n0, n1;
      do {
        g0 = random_vec(rng, 0.05);
        g1 = random_vec(rng, 0.05);
        n0 = random_unit(rng);
        n1 = random_unit(rng);
      } while ((g1 - g0).norm() < 0.04 || n0.cross(n1).norm() < 0.5 || n0.cross((g1 - g0).normalized()).norm() < 0.5 ||
               n1.cross((g1 - g0).normalized()).norm() < 0.5 || std::abs((g1 - g0).normalized().dot(n0 + n1)) < 0.3);
      Pair p = apply(T, g0, g1, n0, n1);
      const double d = (g1 - g0).norm();
      p.tn0 = (p.tn0 + random_vec(rng, s)).normalized();
      p.tn1 = (p.tn1 + random_vec(rng, s)).normalized();
      p.tp0 += random_vec(rng, s * d);
      p.tp1 += random_vec(rng, s * d);
      const auto r = solve(p, o);
      ASSERT_EQ(r.status, PairPoseStatus::Ok);
      expect_valid(r);
      ratio.push_back(rot_angle(r.candidates.front().rotation, T.R) / s);
    }
    std::sort(ratio.begin(), ratio.end());
    p95.push_back(ratio[ratio.size() * 95 / 100]);
    EXPECT_LT(ratio.back(), 30.0) << "sigma " << s;  // worst case: no cliff
  }
  const double lo = *std::min_element(p95.begin(), p95.end());
  const double hi = *std::max_element(p95.begin(), p95.end());
  EXPECT_LT(hi / lo, 2.0);
  EXPECT_LT(hi, 10.0);
}

TEST(Versor, ParallelNormalsAcrossTheLine) {
  // phi = 1: the two normal pairings coincide. Normals perpendicular to the line make the pair
  // symmetric (a half turn about the normal maps it onto itself): both orders fit, order 0 first.
  std::mt19937_64 rng(6);
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid T{random_rotation(rng), random_vec(rng, 0.1)};
    const Pair p = apply(T, Vector3d(0, 0, 0), Vector3d(0.05, 0, 0), Vector3d(0, 0, 1), Vector3d(0, 0, 1));
    const auto r = solve(p);
    ASSERT_EQ(r.status, PairPoseStatus::Ok);
    expect_valid(r);
    EXPECT_LT(rot_err(r.candidates.front().rotation, T.R), 1e-9);
    EXPECT_LT((r.candidates.front().translation - T.t).norm(), 1e-9);
    for (const auto& c : r.candidates)
      if (c.agreement == 3) EXPECT_LT(map_err(c, p), 1e-9);
  }
}

TEST(Versor, ParallelNormalsObliqueToTheLine) {
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid T{random_rotation(rng), random_vec(rng, 0.1)};
    const Vector3d n = Vector3d(0.3, 0.2, 1).normalized();
    const Pair p = apply(T, Vector3d(0.01, 0, 0), Vector3d(0.05, 0.02, 0), n, n);
    const auto r = solve(p);
    ASSERT_EQ(r.status, PairPoseStatus::Ok);
    EXPECT_LT(rot_err(r.candidates.front().rotation, T.R), 1e-9);
    EXPECT_EQ(r.candidates.front().agreement, 3);
  }
}

TEST(Versor, PairingWithAEqualB) {
  // The rotation's axis is the flipped first normal: pairing 0 has A = B.
  std::mt19937_64 rng(8);
  for (int trial = 0; trial < 100; ++trial) {
    const Vector3d n0 = random_unit(rng);
    const double angle = std::uniform_real_distribution<double>(-3.1, 3.1)(rng);
    const Rigid T{versor_rotation(angle, -n0), random_vec(rng, 0.1)};
    const Pair p = apply(T, random_vec(rng, 0.05), random_vec(rng, 0.05), n0, random_unit(rng));
    ASSERT_LT((-n0 - p.tn0).norm(), 1e-12);
    const auto r = solve(p);
    ASSERT_EQ(r.status, PairPoseStatus::Ok);
    EXPECT_LT(rot_err(r.candidates.front().rotation, T.R), 1e-9);
  }
}

TEST(Versor, IdentityAndTinyRotations) {
  std::mt19937_64 rng(9);
  for (double angle : {0.0, 1e-12, 1e-9, 1e-6, 1e-3}) {
    for (int trial = 0; trial < 50; ++trial) {
      const Rigid T{versor_rotation(angle, random_unit(rng)), random_vec(rng, 0.1)};
      const Pair p = apply(T, random_vec(rng, 0.05), random_vec(rng, 0.05), random_unit(rng), random_unit(rng));
      const auto r = solve(p);
      ASSERT_EQ(r.status, PairPoseStatus::Ok);
      EXPECT_LT(rot_err(r.candidates.front().rotation, T.R), 1e-9) << "angle " << angle;
      EXPECT_LT((r.candidates.front().translation - T.t).norm(), 1e-9);
    }
  }
}

TEST(Versor, HalfTurns) {
  std::mt19937_64 rng(10);
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid T{versor_rotation(kPi, random_unit(rng)), random_vec(rng, 0.1)};
    const Pair p = apply(T, random_vec(rng, 0.05), random_vec(rng, 0.05), random_unit(rng), random_unit(rng));
    const auto r = solve(p);
    ASSERT_EQ(r.status, PairPoseStatus::Ok);
    EXPECT_LT(rot_err(r.candidates.front().rotation, T.R), 1e-9);
  }
}

TEST(Versor, DifferenceVectorParallelToANormal) {
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid T{random_rotation(rng), random_vec(rng, 0.1)};
    const Vector3d g0 = random_vec(rng, 0.05);
    const Vector3d u = random_unit(rng);
    const Pair p = apply(T, g0, g0 + 0.04 * u, trial % 2 ? u : Vector3d(-u), random_unit(rng));
    const auto r = solve(p);
    ASSERT_EQ(r.status, PairPoseStatus::Ok);
    EXPECT_LT(rot_err(r.candidates.front().rotation, T.R), 1e-9);
  }
}

TEST(Versor, AllDifferencesParallelUsesTriad) {
  // Normals and line in the xy-plane, rotation about an axis in that plane: the three
  // differences A - B are parallel and no two great circles meet at a point.
  std::mt19937_64 rng(12);
  for (int trial = 0; trial < 100; ++trial) {
    const double a = std::uniform_real_distribution<double>(0, 2 * kPi)(rng);
    const double b = std::uniform_real_distribution<double>(0, 2 * kPi)(rng);
    const double c = std::uniform_real_distribution<double>(0, 2 * kPi)(rng);
    const Vector3d axis(std::cos(c), std::sin(c), 0);
    const double angle = std::uniform_real_distribution<double>(0.2, 3.0)(rng);
    const Rigid T{versor_rotation(angle, axis), random_vec(rng, 0.1)};
    const Pair p = apply(T, Vector3d(0, 0, 0), Vector3d(0.05, 0, 0), Vector3d(std::cos(a), std::sin(a), 0),
                         Vector3d(std::cos(b), std::sin(b), 0));
    const Vector3d d0 = -p.gn0 - p.tn0, d1 = -p.gn1 - p.tn1;
    ASSERT_LT(d0.cross(d1).norm(), 1e-12);  // the case is what it claims
    const auto r = solve(p);
    if (std::abs(std::sin(a)) < 1e-3 && std::abs(std::sin(b)) < 1e-3) {
      EXPECT_EQ(r.status, PairPoseStatus::Underdetermined);
      continue;
    }
    ASSERT_EQ(r.status, PairPoseStatus::Ok);
    EXPECT_LT(rot_err(r.candidates.front().rotation, T.R), 1e-9);
  }
}

TEST(Versor, CoincidentPointsUseTheNormals) {
  std::mt19937_64 rng(13);
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid T{random_rotation(rng), random_vec(rng, 0.1)};
    const Vector3d g = random_vec(rng, 0.05);
    const Pair p = apply(T, g, g, random_unit(rng), random_unit(rng));
    const auto r = solve(p);
    ASSERT_EQ(r.status, PairPoseStatus::Ok);
    EXPECT_EQ(r.candidates.front().agreement, 1);
    EXPECT_LT(rot_err(r.candidates.front().rotation, T.R), 1e-9);
    EXPECT_LT((r.candidates.front().translation - T.t).norm(), 1e-9);
  }
}

TEST(Versor, AntipodalPairIsUnderdetermined) {
  std::mt19937_64 rng(14);
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid T{random_rotation(rng), random_vec(rng, 0.1)};
    const Vector3d g0 = random_vec(rng, 0.05);
    const Vector3d u = random_unit(rng);
    // Fingers facing each other (normals along the line), facing away, or the same way.
    const int kind = trial % 3;
    const Vector3d n0 = kind == 1 ? Vector3d(-u) : u;
    const Vector3d n1 = kind == 0 ? Vector3d(-u) : u;
    const Pair p = apply(T, g0, g0 + 0.05 * u, n0, n1);
    const auto r = solve(p);
    EXPECT_EQ(r.status, PairPoseStatus::Underdetermined);
    EXPECT_TRUE(r.candidates.empty());
  }
  // Within the collinear tolerance is still underdetermined; beyond it, solved.
  PairPoseOptions o;
  o.collinear_tolerance = 1e-3;
  const Vector3d u(1, 0, 0);
  const Rigid T{random_rotation(rng), random_vec(rng, 0.1)};
  const Pair near = apply(T, Vector3d::Zero(), 0.05 * u, versor_rotation(5e-4, Vector3d::UnitZ()) * u, -u);
  EXPECT_EQ(solve(near, o).status, PairPoseStatus::Underdetermined);
  const Pair off = apply(T, Vector3d::Zero(), 0.05 * u, versor_rotation(0.2, Vector3d::UnitZ()) * u, -u);
  const auto r = solve(off, o);
  ASSERT_EQ(r.status, PairPoseStatus::Ok);
  EXPECT_LT(rot_err(r.candidates.front().rotation, T.R), 1e-9);
}

TEST(Versor, InconsistentCorrespondenceHasNoAgreement) {
  // Every angle between two vectors of one side differs from its partner's on the other side
  // (gripper: 0, 90, 90 degrees; target: 90, 45, 132 degrees, or 90, 48, 135 swapped), so no rotation
  // satisfies two pairings.
  const Vector3d z = Vector3d::UnitZ();
  const auto r = solve_pair_pose(Vector3d(0, 0, 0), Vector3d(0.05, 0, 0), z, z, Vector3d(0, 0, 0),
                                 Vector3d(0.05, 0, 0), Vector3d(1, 0, 1).normalized(),
                                 Vector3d(-1, 0.5, 1).normalized());
  EXPECT_EQ(r.status, PairPoseStatus::NoAgreement);
  EXPECT_TRUE(r.candidates.empty());
  EXPECT_STREQ(to_string(r.status), "no_agreement");
}

TEST(Versor, FuzzDegenerateCombinationsNeverNaN) {
  // Vectors drawn from a small set (axes, their negatives, repeats), points coincident or on
  // axes, rotations identity / half turns / about those axes. Consistent data must be mapped
  // exactly whenever a pose is returned; nothing is ever NaN.
  std::mt19937_64 rng(15);
  const std::vector<Vector3d> dirs{Vector3d::UnitX(), Vector3d::UnitY(), Vector3d::UnitZ(), -Vector3d::UnitX(),
                                   -Vector3d::UnitY(), -Vector3d::UnitZ(), Vector3d(1, 1, 0).normalized(),
                                   Vector3d(1, 1, 1).normalized()};
  std::uniform_int_distribution<int> pick(0, static_cast<int>(dirs.size()) - 1);
  int solved = 0, under = 0;
  for (int trial = 0; trial < 5000; ++trial) {
    Matrix3d R;
    switch (trial % 5) {
      case 0: R.setIdentity(); break;
      case 1: R = versor_rotation(kPi, dirs[pick(rng)]); break;
      case 2: R = versor_rotation(kPi / 2 * (1 + pick(rng) % 3), dirs[pick(rng)]); break;
      case 3: R = versor_rotation(1e-10, dirs[pick(rng)]); break;
      default: R = random_rotation(rng);
    }
    const Rigid T{R, trial % 2 ? Vector3d::Zero() : random_vec(rng, 0.1)};
    const Vector3d g0 = trial % 7 == 0 ? Vector3d::Zero() : Vector3d(0.03 * dirs[pick(rng)]);
    const Vector3d g1 = trial % 11 == 0 ? g0 : Vector3d(g0 + 0.05 * dirs[pick(rng)]);
    const Pair p = apply(T, g0, g1, dirs[pick(rng)], dirs[pick(rng)]);
    const auto r = solve(p);
    expect_valid(r);
    ASSERT_NE(r.status, PairPoseStatus::NoAgreement) << "trial " << trial;
    if (r.status == PairPoseStatus::Ok) {
      ++solved;
      EXPECT_LT(map_err(r.candidates.front(), p), 1e-9) << "trial " << trial;
    } else {
      ++under;
    }
  }
  EXPECT_GT(solved, 2000);
  EXPECT_GT(under, 100);
  // Arbitrary unit vectors in any combination, consistent or not: finite output.
  for (int trial = 0; trial < 2000; ++trial) {
    Pair p{0.05 * dirs[pick(rng)], 0.05 * dirs[pick(rng)], dirs[pick(rng)], dirs[pick(rng)],
           0.05 * dirs[pick(rng)], 0.05 * dirs[pick(rng)], dirs[pick(rng)], dirs[pick(rng)]};
    expect_valid(solve(p));
  }
}

TEST(Versor, MinAgreementKeepsExactlyTheFullyAgreeingCandidates) {
  // min_agreement = 3 (with its early rejection of orders whose dot products differ) returns the
  // agreement-3 candidates of the unrestricted solve, no more and no fewer.
  std::mt19937_64 rng(16);
  PairPoseOptions all, full;
  full.min_agreement = 3;
  std::normal_distribution<double> g;
  for (int trial = 0; trial < 600; ++trial) {
    const Rigid T{random_rotation(rng), random_vec(rng, 0.1)};
    const Vector3d n = random_unit(rng);
    Pair p = apply(T, random_vec(rng, 0.05), random_vec(rng, 0.05), n, trial % 3 == 0 ? n : random_unit(rng));
    const double sigma = trial % 2 ? 0.0 : 0.03;
    p.tn0 = (p.tn0 + random_vec(rng, sigma)).normalized();
    p.tn1 = (p.tn1 + random_vec(rng, sigma)).normalized();
    const auto a = solve(p, all), f = solve(p, full);
    std::vector<Matrix3d> want;
    for (const auto& c : a.candidates)
      if (c.agreement == 3) want.push_back(c.rotation);
    ASSERT_EQ(f.candidates.size(), want.size()) << "trial " << trial;
    for (std::size_t k = 0; k < want.size(); ++k) {
      EXPECT_EQ(f.candidates[k].agreement, 3);
      EXPECT_LT(rot_err(f.candidates[k].rotation, want[k]), 1e-12);
    }
    if (want.empty()) EXPECT_NE(f.status, PairPoseStatus::Ok);
  }
}

TEST(Versor, BadInputThrows) {
  const Vector3d z = Vector3d::UnitZ(), o = Vector3d::Zero();
  const double nan = std::nan("");
  EXPECT_THROW(solve_pair_pose(Vector3d(nan, 0, 0), o, z, z, o, o, z, z), std::invalid_argument);
  EXPECT_THROW(solve_pair_pose(o, o, 2 * z, z, o, o, z, z), std::invalid_argument);
  EXPECT_THROW(solve_pair_pose(o, o, z, z, o, o, z, o), std::invalid_argument);
  PairPoseOptions bad;
  bad.angle_tolerance = 0;
  EXPECT_THROW(solve_pair_pose(o, Vector3d::UnitX(), z, z, o, Vector3d::UnitX(), z, z, bad), std::invalid_argument);
  Points two(2, 3), three(3, 3), nrm(2, 3);
  two.setZero();
  three.setZero();
  nrm << 0, 0, 1, 0, 0, 1;
  try {
    solve_pair_pose(three, nrm, two, nrm);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "gripper_points: expected (2,3), got (3,3)");
  }
  Points unnorm = nrm;
  unnorm(1, 2) = 3;
  try {
    solve_pair_pose(two, nrm, two, unnorm);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("target_normals: row 1"), std::string::npos) << e.what();
  }
}
