// Contact wrenches against hand computations.
#include <pairgrasp/wrenches.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace pg = pairgrasp;

TEST(Wrenches, ContactOnTopFaceByHand) {
  // Contact at (0.1, 0, 0.2) on a face whose outward normal is +z; centre at the origin, r = 0.5.
  pg::Points p(1, 3), n(1, 3);
  p << 0.1, 0.0, 0.2;
  n << 0.0, 0.0, 1.0;
  const double mu = 0.5, r = 0.5;
  const pg::Wrenches w = pg::wrench_matrix(p, n, Eigen::Vector3d::Zero(), r, mu, 4);
  ASSERT_EQ(w.rows(), 4);
  // n_in = -z; least-aligned axis is x (tie x, y -> x): t1 = x, t2 = n_in x t1 = -z x x = -y.
  const double f[4][3] = {{mu, 0, -1}, {0, -mu, -1}, {-mu, 0, -1}, {0, mu, -1}};
  for (int k = 0; k < 4; ++k) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(w(k, c), f[k][c], 1e-15) << "edge " << k;
    // torque (p x f) / r written out component by component
    const double px = 0.1, py = 0.0, pz = 0.2;
    const double tx = (py * f[k][2] - pz * f[k][1]) / r;
    const double ty = (pz * f[k][0] - px * f[k][2]) / r;
    const double tz = (px * f[k][1] - py * f[k][0]) / r;
    EXPECT_NEAR(w(k, 3), tx, 1e-15);
    EXPECT_NEAR(w(k, 4), ty, 1e-15);
    EXPECT_NEAR(w(k, 5), tz, 1e-15);
  }
}

TEST(Wrenches, EdgesLieOnTheFrictionCone) {
  pg::Points p = pg::Points::Random(5, 3), n = pg::Points::Random(5, 3);
  const double mu = 0.7;
  const pg::Wrenches w = pg::wrench_matrix(p, n, Eigen::Vector3d(0.1, -0.2, 0.3), 0.25, mu, 8);
  for (Eigen::Index i = 0; i < 5; ++i) {
    const Eigen::Vector3d n_in = -n.row(i).transpose().normalized();
    for (int k = 0; k < 8; ++k) {
      const Eigen::Vector3d f = w.row(i * 8 + k).head<3>().transpose();
      EXPECT_NEAR(f.dot(n_in), 1.0, 1e-12);                         // unit normal component
      EXPECT_NEAR((f - f.dot(n_in) * n_in).norm(), mu, 1e-12);      // tangential part = mu
    }
  }
}

TEST(Wrenches, BadInputThrows) {
  pg::Points p(1, 3), n(1, 3), n2(2, 3);
  p << 0, 0, 0;
  n << 0, 0, 1;
  n2.setZero();
  const Eigen::Vector3d c = Eigen::Vector3d::Zero();
  EXPECT_THROW(pg::wrench_matrix(p, n2, c, 1.0), std::invalid_argument);
  EXPECT_THROW(pg::wrench_matrix(p, n, c, 0.0), std::invalid_argument);
  EXPECT_THROW(pg::wrench_matrix(p, n, c, 1.0, -0.1), std::invalid_argument);
  EXPECT_THROW(pg::wrench_matrix(p, n, c, 1.0, 0.5, 2), std::invalid_argument);
  pg::Points zero = pg::Points::Zero(1, 3);
  EXPECT_THROW(pg::wrench_matrix(p, zero, c, 1.0), std::invalid_argument);
  pg::Points bad = p;
  bad(0, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(pg::wrench_matrix(bad, n, c, 1.0), std::invalid_argument);
}

TEST(Wrenches, SoftContactSamplesTheEllipticLimitSurface) {
  // One contact at (0.1, 0, 0.2), outward normal +z, r = 0.5: pyramid of 4 edges, one ring, poles.
  pg::Points p(1, 3), n(1, 3);
  p << 0.1, 0.0, 0.2;
  n << 0.0, 0.0, 3.0;  // any length
  pg::ContactModel m;
  m.mu = 0.5;
  m.edges = 4;
  m.soft = true;
  m.torsion = 0.01;
  m.soft_rings = 1;
  ASSERT_EQ(m.wrenches_per_contact(), 4 * 3 + 2);
  const double r = 0.5;
  const pg::Wrenches w = pg::wrench_matrix(p, n, Eigen::Vector3d::Zero(), r, m);
  ASSERT_EQ(w.rows(), 14);
  const Eigen::Vector3d n_in(0, 0, -1), arm(0.1, 0, 0.2);
  // the frame: t1 = x (least-aligned axis, tie x/y -> x), t2 = n_in x t1 = -y, rows right-handed
  const Eigen::Matrix3d frame = pg::contact_frame(n.row(0).transpose());
  EXPECT_TRUE(frame.isApprox((Eigen::Matrix3d() << 1, 0, 0, 0, -1, 0, 0, 0, -1).finished(), 1e-15));
  EXPECT_NEAR(frame.determinant(), 1.0, 1e-15);
  for (int k = 0; k < 14; ++k) {
    const Eigen::Vector3d f = w.row(k).head<3>().transpose();
    const double moment = (r * w.row(k).tail<3>().transpose() - arm.cross(f)).dot(n_in);
    const double ft = (f - f.dot(n_in) * n_in).norm();
    EXPECT_NEAR(f.dot(n_in), 1.0, 1e-14) << k;
    EXPECT_NEAR(std::pow(ft / m.mu, 2) + std::pow(moment / *m.torsion, 2), 1.0, 1e-12) << k;  // on the ellipse
  }
  // ring at phi = pi/4: positive moment for rows 4..7, negative for 8..11; then the poles +-torsion
  const double s = std::sin(std::acos(-1.0) / 4) * *m.torsion;
  for (int k = 4; k < 8; ++k) {
    const Eigen::Vector3d f = w.row(k).head<3>().transpose();
    EXPECT_NEAR((r * w.row(k).tail<3>().transpose() - arm.cross(f)).dot(n_in), s, 1e-14) << k;
  }
  EXPECT_NEAR(w(12, 5) * r, -(0.01), 1e-15);  // +torsion about n_in = -z: torque z = -0.01
  EXPECT_NEAR(w(13, 5) * r, 0.01, 1e-15);
  m.torsion.reset();
  EXPECT_THROW(pg::wrench_matrix(p, n, Eigen::Vector3d::Zero(), r, m), std::invalid_argument);
}
