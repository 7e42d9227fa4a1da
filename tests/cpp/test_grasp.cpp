// Closing onto contact and contacts, against facts from the dimensions: a parallel jaw closes on
// a box to the box's width, runs to its limit on air, stops at an obstacle plate; its contacts
// lie on the two gripped faces with normals -+x; the Barrett hand's fingers stop at a box.
#include <pairgrasp/evaluation.hpp>
#include <pairgrasp/grasp.hpp>

#include <Eigen/QR>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <stdexcept>
#include <tuple>
#include <vector>

#include "test_hands.hpp"
#include "test_meshes.hpp"
#include "../../cpp/src/nnls.hpp"

using namespace pairgrasp;
using Eigen::Vector3d;
namespace tmesh = pairgrasp::testing_meshes;
namespace th = pairgrasp::testing_hands;

namespace {

Eigen::VectorXd dofs1(double v) { return Eigen::VectorXd::Constant(1, v); }

// The gripped box: 50 mm wide in x, 40 mm in y, z in [0.06, 0.11] of the jaw's wrist frame
// (the fingers span z in [0.05, 0.12], pads at x = -+opening/2, 20 mm wide in y).
Mesh jaw_box(double dx = 0.0) {
  return tmesh::box_mesh(Vector3d(-0.025 + dx, -0.02, 0.06), Vector3d(0.025 + dx, 0.02, 0.11), 4, "jaw box");
}

// The parallel jaw closed on jaw_box() at the wrist's identity: its DOFs and contacts (both pads).
struct JawGrasp {
  Hand jaw = th::parallel_jaw();
  Eigen::VectorXd dofs;
  Contacts both;
  JawGrasp() {
    CheckOptions opt;
    opt.contact_gap = 0.001;
    const GraspChecker checker(jaw, jaw_box(), Mask(), {}, opt);
    dofs = close_fingers(checker, Pose::Identity(), dofs1(0.08)).dofs;
    both = find_contacts(checker, Pose::Identity(), dofs);
  }
  // The left pad's contacts alone.
  std::vector<std::tuple<Vector3d, Vector3d, std::string>> left() const {
    std::vector<std::tuple<Vector3d, Vector3d, std::string>> out;
    for (int k = 0; k < both.points.rows(); ++k)
      if (both.link_names[k] == "pj_left_finger")
        out.emplace_back(both.points.row(k).transpose(), both.normals.row(k).transpose(), both.link_names[k]);
    return out;
  }
};

// The Barrett hand at q = (0.3, 0.8, 0.8, 0.8) with a turned and moved wrist: a point p on finger 3's
// distal link and the direction u that link closes in there (target frame).
struct FingerThreeMotion {
  Hand bh = th::barrett();
  Eigen::Vector4d q{0.3, 0.8, 0.8, 0.8};
  Pose wrist = Pose::Identity();
  Vector3d p, u;
  FingerThreeMotion() {
    wrist.linear() = Eigen::AngleAxisd(0.7, Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    wrist.translation() = Vector3d(0.1, -0.2, 0.05);
    const int f3 = bh.link_index("bh_f3_dist");
    const Vector3d tip_local = bh.links()[f3].mesh.vertices.colwise().mean().transpose();  // a point on the link
    Eigen::Vector4d q1 = q;
    q1[3] += 1e-3;
    const Vector3d a0 = bh.link_poses(q)[f3] * tip_local, a1 = bh.link_poses(q1)[f3] * tip_local;
    u = wrist.linear() * (a1 - a0).normalized();
    p = wrist * a0;
  }
};

}  // namespace

TEST(Grasp, ClosingDirectionsFollowTheActiveSurfaces) {
  // Parallel jaw: the opening (pad distance) grows with the DOF, so closing decreases it.
  const Hand jaw = th::parallel_jaw();
  EXPECT_EQ(closing_directions(jaw, dofs1(0.04))[0], -1);
  EXPECT_EQ(closing_directions(jaw, dofs1(0.08))[0], -1);  // at the upper limit too
  EXPECT_EQ(closing_directions(jaw, dofs1(0.0))[0], -1);
  // Barrett: flexion curls the fingers' inner faces forward (closes); the spread swings fingers
  // sideways about the palm normal (does not close).
  const Hand bh = th::barrett();
  for (const Eigen::Vector4d q : {Eigen::Vector4d(0, 0, 0, 0), Eigen::Vector4d(0.5, 0.7, 1.2, 0.3),
                                  Eigen::Vector4d(3.0, 2.0, 2.44, 1.0)}) {
    const Eigen::VectorXi d = closing_directions(bh, q);
    EXPECT_EQ(d, Eigen::Vector4i(0, 1, 1, 1)) << "at " << q.transpose() << ": " << d.transpose();
  }
  EXPECT_THROW(closing_directions(bh, Eigen::VectorXd::Zero(3)), std::invalid_argument);
}

TEST(Grasp, ParallelJawClosesToTheBoxWidth) {
  const Hand jaw = th::parallel_jaw();
  CheckOptions opt;
  opt.contact_gap = 0.001;
  const GraspChecker checker(jaw, jaw_box(), Mask(), {}, opt);
  const CloseResult r = close_fingers(checker, Pose::Identity(), dofs1(0.08));
  ASSERT_EQ(r.reasons.size(), 1u);
  EXPECT_EQ(r.reasons[0], StopReason::Contact);
  EXPECT_EQ(r.directions[0], -1);
  // Both pads stop within the gap of the x = -+0.025 faces: opening = 0.05 + 2 * clearance.
  EXPECT_GT(r.dofs[0], 0.05);
  EXPECT_LE(r.dofs[0], 0.05 + 2 * opt.contact_gap + 1e-12);
  EXPECT_NEAR(r.clearance[0], (r.dofs[0] - 0.05) / 2, 1e-9);
  EXPECT_FALSE(r.start_penetrating);
  EXPECT_FALSE(r.check.collision);
  EXPECT_FALSE(r.check.pruned);
  EXPECT_GT(r.iterations, 0);
  EXPECT_LT(r.iterations, 100);  // conservative advancement converges in a few steps

  // Contacts: on the two gripped faces only, normals -+x, pads within the gap.
  const Contacts c = find_contacts(checker, Pose::Identity(), r.dofs);
  ASSERT_GT(c.points.rows(), 0);
  int left = 0, right = 0;
  std::set<std::tuple<int, long, long, long>> cells;
  for (int k = 0; k < c.points.rows(); ++k) {
    const Vector3d p = c.points.row(k), n = c.normals.row(k), t = c.target_points.row(k);
    const bool on_left = p.x() < 0;
    EXPECT_NEAR(std::abs(t.x()), 0.025, 1e-12);  // on a gripped face
    EXPECT_NEAR((n - Vector3d(on_left ? -1 : 1, 0, 0)).norm(), 0.0, 1e-12);
    EXPECT_NEAR(std::abs(p.x()), r.dofs[0] / 2, 1e-12);  // a pad point
    EXPECT_NEAR(c.distances[k], r.dofs[0] / 2 - 0.025, 1e-12);
    EXPECT_LE(std::abs(p.y()), 0.01 + 1e-12);            // pad width
    EXPECT_GE(p.z(), 0.06 - 1e-12);                      // pad overlap with the box in z
    EXPECT_LE(p.z(), 0.11 + 1e-12);
    EXPECT_EQ(c.link_names[k], on_left ? "pj_left_finger" : "pj_right_finger");
    EXPECT_EQ(jaw.links()[c.links[k]].name, c.link_names[k]);
    (on_left ? left : right)++;
    // Thinned: at most one contact per link per 4 mm cell.
    const double cell = opt.contact_cell;
    EXPECT_TRUE(cells.insert({c.links[k], std::lround(std::floor(p.x() / cell)), std::lround(std::floor(p.y() / cell)),
                              std::lround(std::floor(p.z() / cell))}).second);
  }
  // The 20 mm x 50 mm overlap holds 5..6 x 13..14 cells of 4 mm per pad.
  EXPECT_GE(left, 5 * 13);
  EXPECT_LE(left, 6 * 14);
  EXPECT_EQ(left, right);
  EXPECT_EQ(c.occluded_count, 0);
}

namespace {

// One contact per row: a point (target frame = wrist frame here), the target's outward normal, a link.
Contacts contacts_of(const Hand& hand, const std::vector<std::tuple<Vector3d, Vector3d, std::string>>& rows) {
  Contacts c;
  c.points.resize(static_cast<Eigen::Index>(rows.size()), 3);
  c.normals.resize(static_cast<Eigen::Index>(rows.size()), 3);
  for (std::size_t k = 0; k < rows.size(); ++k) {
    c.points.row(static_cast<Eigen::Index>(k)) = std::get<0>(rows[k]).transpose();
    c.normals.row(static_cast<Eigen::Index>(k)) = std::get<1>(rows[k]).normalized().transpose();
    c.links.push_back(hand.link_index(std::get<2>(rows[k])));
    c.link_names.push_back(std::get<2>(rows[k]));
  }
  return c;
}

}  // namespace

TEST(Grasp, ClosingPushOfTheJawsPadsAndOfAFingerAgainstThePalm) {
  // Parallel jaw on the box: one DOF moves both pads and their pushes (+x and -x) cancel: 1.
  const JawGrasp g;
  const ClosingPush jaw_push = closing_push(g.jaw, Pose::Identity(), g.dofs, g.both);
  EXPECT_NEAR(jaw_push.opposition, 1.0, 1e-9);
  EXPECT_NEAR(jaw_push.drive, 1.0, 1e-9);  // the pads close straight into the faces
  // One pad only (the left pad's contacts): nothing pushes back, its own pushes do not cancel.
  EXPECT_NEAR(closing_push(g.jaw, Pose::Identity(), g.dofs, contacts_of(g.jaw, g.left())).opposition, 0.0, 1e-9);

  // Barrett, a wrist turned and moved: a contact on finger 3's distal link whose inward normal is
  // the direction the link closes in there (so it pushes along it), and a palm contact whose
  // inward normal makes the angle a with the reverse of that push: the opposition is cos(a).
  const FingerThreeMotion f;
  const Hand& bh = f.bh;
  const Eigen::Vector4d& q = f.q;
  const Pose& wrist = f.wrist;
  const Vector3d &u = f.u, &p = f.p;
  const Vector3d side = u.unitOrthogonal();
  for (double a : {0.0, 0.4, 1.0, 1.5}) {
    // the palm's inward normal is cos(a) (-u) + sin(a) side; outward normals are their negatives
    const Vector3d palm_in = std::cos(a) * -u + std::sin(a) * side;
    const Contacts c = contacts_of(bh, {{p, -u, "bh_f3_dist"}, {wrist * Vector3d(0, 0, 0.08), -palm_in, "bh_palm"}});
    const ClosingPush push = closing_push(bh, wrist, q, c);
    EXPECT_NEAR(push.opposition, std::cos(a), 1e-6) << "a = " << a;
    EXPECT_NEAR(push.drive, 1.0, 1e-6);  // the finger's contact normal is its closing motion
  }
  // Bad input: a wrist that is not rigid, a contact point that is not finite.
  const Contacts one = contacts_of(bh, {{p, -u, "bh_f3_dist"}});
  Pose sheared = wrist;
  sheared.matrix()(0, 1) += 0.1;
  EXPECT_THROW(closing_push(bh, sheared, q, one), std::invalid_argument);
  Contacts nan_point = one;
  nan_point.points(0, 0) = std::nan("");
  EXPECT_THROW(closing_push(bh, wrist, q, nan_point), std::invalid_argument);
  // No closing DOF moves a contact (the palm only): -1.
  const ClosingPush none = closing_push(bh, wrist, q, contacts_of(bh, {{p, u, "bh_palm"}}));
  EXPECT_EQ(none.opposition, -1.0);
  EXPECT_EQ(none.drive, -1.0);
  EXPECT_THROW(closing_push(bh, wrist, Eigen::VectorXd::Zero(3), contacts_of(bh, {})), std::invalid_argument);
  Contacts wrong = contacts_of(bh, {{p, -u, "bh_f3_dist"}});
  wrong.links[0] = -1;
  EXPECT_THROW(closing_push(bh, wrist, q, wrong), std::invalid_argument);
}

TEST(Grasp, ClosingFrictionOfTheJawsPadsAndOfAFingerAgainstThePalmIsTheTangentOfTheTilt) {
  // Parallel jaw on the box: the pads press straight into opposite faces, no friction needed; one pad
  // alone pushes the box away (infinite); nothing pushed (no contact) is NaN.
  const JawGrasp g;
  const Vector3d centre(0.0, 0.0, 0.085);
  EXPECT_EQ(closing_friction(g.jaw, Pose::Identity(), g.dofs, g.both, centre), 0.0);
  EXPECT_EQ(closing_friction(g.jaw, Pose::Identity(), g.dofs, contacts_of(g.jaw, g.left()), centre),
            std::numeric_limits<double>::infinity());
  EXPECT_TRUE(std::isnan(closing_friction(g.jaw, Pose::Identity(), g.dofs, contacts_of(g.jaw, {}), centre)));

  // Barrett, wrist turned and moved: finger 3's distal link pushes along its own closing motion u,
  // and the palm pushes back on the same line through a contact whose inward normal makes the angle
  // a with -u: the force along the line is a off that normal, so the palm needs friction tan(a).
  const FingerThreeMotion f;
  const Hand& bh = f.bh;
  const Eigen::Vector4d& q = f.q;
  const Pose& wrist = f.wrist;
  const Vector3d &u = f.u, &p = f.p, palm = p + 0.03 * u;
  const Vector3d side = u.unitOrthogonal();
  ClosingFrictionOptions fine;
  fine.edges = 64;  // within 1 / cos(pi / 64) - 1 = 0.12% of the cone
  fine.tolerance = 1e-5;
  for (double a : {0.0, 0.2, 0.5, 0.9}) {
    const Vector3d palm_in = std::cos(a) * -u + std::sin(a) * side;
    const Contacts c = contacts_of(bh, {{p, -u, "bh_f3_dist"}, {palm, -palm_in, "bh_palm"}});
    EXPECT_NEAR(closing_friction(bh, wrist, q, c, 0.5 * (p + palm), fine), std::tan(a), 2e-3 * std::tan(a) + 2e-5)
        << "a = " << a;
  }
  ClosingFrictionOptions bad;
  bad.mu_max = -1.0;
  EXPECT_THROW(closing_friction(bh, wrist, q, contacts_of(bh, {}), Vector3d::Zero(), bad), std::invalid_argument);
  EXPECT_THROW(closing_friction(bh, wrist, Eigen::VectorXd::Zero(3), contacts_of(bh, {}), Vector3d::Zero()),
               std::invalid_argument);
  Contacts wrong = contacts_of(bh, {{p, -u, "bh_f3_dist"}});
  wrong.links[0] = 99;
  EXPECT_THROW(closing_friction(bh, wrist, q, wrong, Vector3d::Zero()), std::invalid_argument);
}

TEST(Grasp, NonnegativeLeastSquaresMatchesAScanOfEveryActiveSet) {
  // The x >= 0 minimising |A x - b| is the least-squares solution on some set of columns with
  // every coefficient >= 0; scanning all 2^n sets finds the least residual, which the active-set
  // method must reach. Tall, square and wide systems, with b inside and outside the cone of A.
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  for (int trial = 0; trial < 60; ++trial) {
    const int rows = 3 + trial % 5, cols = 1 + trial % 8;
    Eigen::MatrixXd A(rows, cols);
    Eigen::VectorXd b(rows);
    for (int i = 0; i < rows; ++i) {
      for (int j = 0; j < cols; ++j) A(i, j) = normal(rng);
      b[i] = normal(rng);
    }
    if (trial % 3 == 0) b = A * Eigen::VectorXd::Random(cols).cwiseAbs();  // inside the cone
    double best = b.norm();  // the empty set
    for (int mask = 1; mask < (1 << cols); ++mask) {
      std::vector<int> set;
      for (int j = 0; j < cols; ++j)
        if (mask >> j & 1) set.push_back(j);
      Eigen::MatrixXd As(rows, static_cast<Eigen::Index>(set.size()));
      for (std::size_t k = 0; k < set.size(); ++k) As.col(static_cast<Eigen::Index>(k)) = A.col(set[k]);
      const Eigen::VectorXd z = As.colPivHouseholderQr().solve(b);
      if ((z.array() >= 0.0).all()) best = std::min(best, (As * z - b).norm());
    }
    const Eigen::VectorXd x = detail::nonnegative_least_squares(A, b);
    ASSERT_EQ(x.size(), cols);
    EXPECT_TRUE((x.array() >= 0.0).all()) << "trial " << trial;
    EXPECT_NEAR((A * x - b).norm(), best, 1e-9 * (1.0 + b.norm())) << "trial " << trial;
  }
}

TEST(Grasp, ContactsOnOccludedFacesAreOnlyCounted) {
  const Hand jaw = th::parallel_jaw();
  const Mesh box = jaw_box();
  Mask free = Mask::Constant(box.faces.rows(), true);
  for (int f = 0; f < box.faces.rows(); ++f)
    if (box.face_normal(f).x() > 0.5) free[f] = false;  // the +x face is held by someone
  const GraspChecker checker(jaw, box, free);
  const CloseResult r = close_fingers(checker, Pose::Identity(), dofs1(0.08));
  EXPECT_EQ(r.reasons[0], StopReason::Contact);
  EXPECT_TRUE(r.check.touches_occluded);  // the right pad touches the occluded face
  EXPECT_TRUE(r.check.pruned);
  const Contacts c = find_contacts(checker, Pose::Identity(), r.dofs);
  ASSERT_GT(c.points.rows(), 0);
  for (int k = 0; k < c.points.rows(); ++k) EXPECT_LT(c.normals(k, 0), -0.5);  // -x face only
  EXPECT_EQ(c.occluded_count, c.points.rows());  // the mirror-image pad, same cell count
}

TEST(Grasp, ClosingOnAirRunsToTheLimit) {
  const Hand jaw = th::parallel_jaw();
  const GraspChecker checker(jaw, jaw_box(1.0));  // the box 1 m away
  const CloseResult r = close_fingers(checker, Pose::Identity(), dofs1(0.06));
  EXPECT_EQ(r.reasons[0], StopReason::Limit);
  EXPECT_EQ(r.dofs[0], 0.0);  // the lower limit
  EXPECT_FALSE(r.check.collision);
  EXPECT_EQ(find_contacts(checker, Pose::Identity(), r.dofs).points.rows(), 0);
}

TEST(Grasp, ClosingStopsAtAnObstacle) {
  const Hand jaw = th::parallel_jaw();
  // A plate between the left pad and the box: x in [-0.035, -0.03], spanning the pad (and clear
  // of the jaw's base, z < 0.05).
  const Mesh plate = tmesh::box_mesh(Vector3d(-0.035, -0.03, 0.055), Vector3d(-0.03, 0.03, 0.13), 1, "plate");
  const GraspChecker checker(jaw, jaw_box(), Mask(), {{"plate", plate}});
  // From opening 0.08 the left pad (x = -0.04) is 5 mm from the plate, the right one 15 mm from
  // the box: the DOF stops when the left pad reaches the plate, opening = 2 * (0.035 + clearance).
  const CloseResult r = close_fingers(checker, Pose::Identity(), dofs1(0.08));
  EXPECT_EQ(r.reasons[0], StopReason::Contact);
  EXPECT_GT(r.dofs[0], 0.07);
  EXPECT_LE(r.dofs[0], 0.07 + 2 * checker.options().contact_gap + 1e-12);
  EXPECT_FALSE(r.check.collision);
  EXPECT_FALSE(r.check.pruned);
  // No contact with the target: the right pad is still 10 mm from the box.
  EXPECT_EQ(find_contacts(checker, Pose::Identity(), r.dofs).points.rows(), 0);
}

TEST(Grasp, StartingInsideIsBlocked) {
  const Hand jaw = th::parallel_jaw();
  const GraspChecker checker(jaw, jaw_box());
  // Opening 0.03 puts each pad 10 mm inside the 50 mm box.
  const CloseResult r = close_fingers(checker, Pose::Identity(), dofs1(0.03));
  EXPECT_TRUE(r.start_penetrating);
  EXPECT_EQ(r.reasons[0], StopReason::Blocked);
  EXPECT_EQ(r.dofs[0], 0.03);
  EXPECT_TRUE(r.check.pruned);
}

TEST(Grasp, BarrettFingersStopAtABoxEdgeAtTheAnalyticAngle) {
  const Hand bh = th::barrett();
  // A box 60 x 60 mm, z in [0.1, 0.15] (above the knuckles, below the distal links). At spread 0
  // fingers 1 and 2 (x = -+0.025) pivot about x-parallel axes at y = 0.05, z = 0.095, finger 3
  // (x = 0) mirrored at y = -0.05. The proximal link is 18 mm thick: its inner face lies 9 mm
  // from the pivot, with normal n = (-cos t, -sin t) in (y, z) at flexion t. It meets the box's
  // top edge E = (0.03, 0.15) when (E - pivot).n = 0.009, i.e. 0.02 cos t - 0.055 sin t = 0.009;
  // before that the edge is (E - pivot).n - 0.009 from the face.
  const Mesh box = tmesh::box_mesh(Vector3d(-0.03, -0.03, 0.1), Vector3d(0.03, 0.03, 0.15), 2, "box");
  const GraspChecker checker(bh, box);
  const CloseResult r = close_fingers(checker, Pose::Identity(), Eigen::Vector4d(0, 0, 0, 0));
  EXPECT_EQ(r.reasons[0], StopReason::Fixed);
  EXPECT_EQ(r.dofs[0], 0.0);
  const double t_star = std::acos(0.009 / std::hypot(0.02, 0.055)) - std::atan2(0.055, 0.02);
  EXPECT_NEAR(t_star, 0.1944, 1e-3);
  const double gap = checker.options().contact_gap;
  for (int k = 1; k < 4; ++k) {
    EXPECT_EQ(r.reasons[k], StopReason::Contact) << "DOF " << k;
    const double t = r.dofs[k];
    const double edge_to_face = (0.02 * std::cos(t) - 0.055 * std::sin(t)) - 0.009;
    EXPECT_LT(t, t_star) << "DOF " << k;
    EXPECT_GT(edge_to_face, 0.0) << "DOF " << k;
    EXPECT_LE(edge_to_face, gap + 1e-12) << "DOF " << k;
    EXPECT_NEAR(r.clearance[k], edge_to_face, 1e-7) << "DOF " << k;
  }
  EXPECT_FALSE(r.check.collision);
  EXPECT_FALSE(r.check.pruned);
  // Closing is deterministic.
  const CloseResult again = close_fingers(checker, Pose::Identity(), Eigen::Vector4d(0, 0, 0, 0));
  EXPECT_EQ(again.dofs, r.dofs);
  // Contacts on all three proximal links, at the box's top edge (y = -+0.03, z = 0.15): the
  // inner face, tilted by t from the side face, is within the gap of the side face down to
  // gap / sin t below the edge, and of the top face up to gap / cos t inwards.
  const Contacts c = find_contacts(checker, Pose::Identity(), r.dofs);
  std::set<std::string> links(c.link_names.begin(), c.link_names.end());
  EXPECT_EQ(links, (std::set<std::string>{"bh_f1_prox", "bh_f2_prox", "bh_f3_prox"}));
  const double down = gap / std::sin(t_star - 0.02), in = gap / std::cos(t_star);
  for (int k = 0; k < c.points.rows(); ++k) {
    const double y = std::abs(c.target_points(k, 1)), z = c.target_points(k, 2);
    const bool on_side = std::abs(y - 0.03) < 1e-12 && z >= 0.15 - down && z <= 0.15 + 1e-12;
    const bool on_top = std::abs(z - 0.15) < 1e-12 && y >= 0.03 - in && y <= 0.03 + 1e-12;
    EXPECT_TRUE(on_side || on_top) << c.target_points.row(k);
  }
}

TEST(Grasp, FineTuningFromAGivenStartEqualsFineTuningFromItsPose) {
  // The planner hands fine_tune() the search's evaluation of a candidate instead of closing and
  // scoring it again: same trials, same best grasp, bit for bit.
  const Hand bh = th::barrett();
  const Mesh box = tmesh::box_mesh(Vector3d(-0.03, -0.03, 0.1), Vector3d(0.03, 0.03, 0.15), 2, "box");
  const GraspChecker checker(bh, box);
  FineTuneOptions fo;
  fo.iterations = 8;
  fo.seed = 5;
  fo.threads = 2;
  fo.evaluate.contacts_per_link = 4;
  fo.evaluate.quality.joggle = true;
  EvaluateOptions eo = fo.evaluate;
  eo.close = true;
  const Eigen::Vector4d q(0, 0, 0, 0);
  const GraspEvaluation start = evaluate_grasp(checker, Pose::Identity(), q, eo);
  ASSERT_FALSE(start.pruned);
  ASSERT_TRUE(start.quality.epsilon_computed);
  const FineTuneResult a = fine_tune(checker, Pose::Identity(), q, fo);
  const FineTuneResult b = fine_tune(checker, start, fo);
  EXPECT_EQ(a.trials, b.trials);
  EXPECT_EQ(a.kept, b.kept);
  EXPECT_EQ(a.improvements, b.improvements);
  EXPECT_EQ(a.improved, b.improved);
  EXPECT_EQ(a.start.quality.epsilon, b.start.quality.epsilon);
  ASSERT_TRUE(a.best && b.best);
  EXPECT_TRUE(a.best->wrist.isApprox(b.best->wrist, 0.0));
  EXPECT_EQ(a.best->dofs, b.best->dofs);
  EXPECT_EQ(a.best->quality.epsilon, b.best->quality.epsilon);
  // A start whose epsilon a search only bounded is refused.
  GraspEvaluation bounded = start;
  bounded.quality.epsilon_computed = false;
  EXPECT_THROW(fine_tune(checker, bounded, fo), std::invalid_argument);
}

TEST(Grasp, BadInputThrows) {
  const Hand jaw = th::parallel_jaw();
  const GraspChecker checker(jaw, jaw_box());
  CloseOptions o;
  o.directions = Eigen::VectorXi::Constant(2, 1);
  EXPECT_THROW(close_fingers(checker, Pose::Identity(), dofs1(0.08), o), std::invalid_argument);
  o.directions = Eigen::VectorXi::Constant(1, 2);
  EXPECT_THROW(close_fingers(checker, Pose::Identity(), dofs1(0.08), o), std::invalid_argument);
  Pose scaled = Pose::Identity();
  scaled.linear() *= 2.0;
  EXPECT_THROW(close_fingers(checker, scaled, dofs1(0.08)), std::invalid_argument);
  EXPECT_THROW(find_contacts(checker, scaled, dofs1(0.08)), std::invalid_argument);
  EXPECT_THROW(find_contacts(checker, Pose::Identity(), dofs1(0.5)), std::invalid_argument);
  EXPECT_THROW(close_fingers(checker, Pose::Identity(), Eigen::VectorXd::Zero(2)), std::invalid_argument);
  EXPECT_STREQ(to_string(StopReason::Contact), "contact");
  EXPECT_STREQ(to_string(StopReason::Limit), "limit");
  EXPECT_STREQ(to_string(StopReason::Blocked), "blocked");
  EXPECT_STREQ(to_string(StopReason::Fixed), "fixed");
}
