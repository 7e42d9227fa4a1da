// GraspChecker through distance fields against the exact path (use_distance_field = false): on
// random poses of both bundled hands on every bundled target, with and without the paint files
// and with a table under the target, every decision is the same (the checks' and the per-link
// states settling uses) and depths agree within the field's bound. Most poses put a random point of a random link within a few millimetres of a
// random target surface point (links straddling the surface), the rest anywhere near the target.
// Closing and contacts are compared the same way. An open target's unsigned field, and a split
// target checked with the geometry of the mesh as given, decide as the exact path does.
#include <pairgrasp/collision.hpp>
#include <pairgrasp/free_surface.hpp>
#include <pairgrasp/grasp.hpp>
#include <pairgrasp/paint.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "test_meshes.hpp"
#include "test_scale.hpp"
#include "../../cpp/src/collision_internal.hpp"

using namespace pairgrasp;
using Eigen::Vector3d;

namespace {

std::string model(const std::string& rel) { return std::string(PAIRGRASP_MODEL_DIR) + "/" + rel; }

Vector3d on_surface(const Mesh& m, std::mt19937_64& rng, Vector3d* normal = nullptr) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::uniform_int_distribution<Eigen::Index> face(0, m.faces.rows() - 1);
  const Eigen::Index f = face(rng);
  double a = u(rng), b = u(rng);
  if (a + b > 1.0) a = 1.0 - a, b = 1.0 - b;
  const Vector3d p0 = m.vertices.row(m.faces(f, 0)).transpose(), p1 = m.vertices.row(m.faces(f, 1)).transpose(),
                 p2 = m.vertices.row(m.faces(f, 2)).transpose();
  if (normal) *normal = (p1 - p0).cross(p2 - p0).normalized();
  return p0 + a * (p1 - p0) + b * (p2 - p0);
}

struct Poses {
  std::vector<Pose> wrists;
  std::vector<Eigen::VectorXd> dofs;
};

// `backoff`: most near-contact poses are then moved out along the target's normal (bisection on
// its depth, 8 steps) until the target depth is about a random value in [0, 2.5 mm], so that many
// straddle the tolerance or barely touch.
Poses random_poses(const Hand& hand, const Mesh& target, int n, std::uint64_t seed, const GraspChecker& backoff) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g;
  const Eigen::VectorXd lo = hand.dof_lower(), hi = hand.dof_upper();
  std::uniform_int_distribution<std::size_t> pick(0, hand.links().size() - 1);
  Poses out;
  for (int k = 0; k < n; ++k) {
    Eigen::VectorXd q(lo.size());
    for (Eigen::Index i = 0; i < q.size(); ++i) q[i] = lo[i] + (hi[i] - lo[i]) * u(rng);
    Pose w = Pose::Identity();
    w.linear() = Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
    if (k % 8 == 7) {  // anywhere within 5 cm of the target's box
      const Eigen::AlignedBox3d& b = target.bounds;
      w.translation() = b.min() - Vector3d::Constant(0.05) +
                        (b.sizes() + Vector3d::Constant(0.1)).cwiseProduct(Vector3d(u(rng), u(rng), u(rng)));
    } else {  // a link point 3 mm inside .. 2 mm outside a target surface point
      const std::size_t l = pick(rng);
      const Pose link = hand.link_poses(q)[l];
      const Vector3d y = link * on_surface(hand.links()[l].mesh, rng);
      Vector3d n;
      const Vector3d x = on_surface(target, rng, &n);
      w.translation() = x + n * (-0.003 + 0.005 * u(rng)) - w.linear() * y;
      if (k % 4 != 0) {
        const double want = 0.0025 * u(rng);
        double a = 0.0, b = 0.06;
        for (int it = 0; it < 8; ++it) {
          Pose m = w;
          m.translation() += n * (0.5 * (a + b));
          (backoff.check(m, q, false).target_depth > want ? a : b) = 0.5 * (a + b);
        }
        w.translation() += n * b;
      }
    }
    out.wrists.push_back(w);
    out.dofs.push_back(q);
  }
  return out;
}

struct Tally {
  int poses = 0, differing = 0, pruned = 0, penetrating = 0, occluded = 0, obstacle = 0, colliding = 0;
};

void compare(const GraspChecker& exact, const GraspChecker& field, const Poses& p, bool exact_depth, Tally& t) {
  const auto a = exact.check_many(p.wrists, p.dofs, 0, exact_depth);
  const auto b = field.check_many(p.wrists, p.dofs, 0, exact_depth);
  const double bound = 0.5 * std::sqrt(3.0) * field.options().field_cell + 1e-7;
  const double tol = exact.options().depth_tolerance;
  for (std::size_t k = 0; k < a.size(); ++k) {
    SCOPED_TRACE("pose " + std::to_string(k));
    const CheckResult &x = a[k], &y = b[k];
    ++t.poses;
    const bool same = x.pruned == y.pruned && x.penetrating == y.penetrating &&
                      x.obstacle_collision == y.obstacle_collision && x.touches_occluded == y.touches_occluded &&
                      x.collision == y.collision;
    t.differing += !same;
    t.pruned += x.pruned;
    t.penetrating += x.penetrating;
    t.occluded += x.touches_occluded;
    t.obstacle += x.obstacle_collision;
    t.colliding += x.collision;
    EXPECT_TRUE(same) << x.reason << " | " << y.reason;
    // The string-free per-link states that settling and closing use (without FCL's triangle test
    // where the fields leave it open): the same decisions, a depth beyond the tolerance in both.
    const std::vector<Pose> poses = detail::CheckerAccess::impl(exact).target_frame_poses(p.wrists[k], p.dofs[k]);
    for (std::size_t l = 0; l < poses.size(); ++l) {
      const LinkStatus se = exact.link_status(static_cast<int>(l), poses[l]);
      const LinkStatus sf = field.link_status(static_cast<int>(l), poses[l]);
      const bool state_same = se.pruned == sf.pruned && se.penetrating == sf.penetrating;
      t.differing += !state_same;
      EXPECT_TRUE(state_same) << "link_state of link " << l;
      if (se.penetrating && sf.penetrating && !x.obstacle_collision) EXPECT_TRUE(se.depth > tol && sf.depth > tol);
    }
    ASSERT_EQ(x.links.size(), y.links.size());
    for (std::size_t l = 0; l < x.links.size(); ++l) {
      EXPECT_EQ(x.links[l].colliding, y.links[l].colliding) << x.links[l].link;
      EXPECT_EQ(x.links[l].touches_occluded, y.links[l].touches_occluded) << x.links[l].link;
      EXPECT_EQ(x.links[l].with, y.links[l].with) << x.links[l].link;
    }
    ASSERT_EQ(x.pairs.size(), y.pairs.size());
    for (std::size_t i = 0; i < x.pairs.size(); ++i) {
      EXPECT_EQ(x.pairs[i].link, y.pairs[i].link);
      EXPECT_EQ(x.pairs[i].other, y.pairs[i].other);
      EXPECT_EQ(x.pairs[i].intersecting, y.pairs[i].intersecting) << x.pairs[i].link;
      EXPECT_EQ(x.pairs[i].inside, y.pairs[i].inside) << x.pairs[i].link;
      const double dx = x.pairs[i].depth, dy = y.pairs[i].depth;
      if (exact_depth || (dx <= tol && dy <= tol) || x.pairs[i].obstacle)
        EXPECT_NEAR(dx, dy, bound) << x.pairs[i].link << " with " << x.pairs[i].other;
      else
        EXPECT_TRUE(dx > tol && dy > tol) << dx << " " << dy;
    }
    if (exact_depth) EXPECT_NEAR(x.target_depth, y.target_depth, bound);
  }
}

CheckOptions with_field(bool on) {
  CheckOptions o;
  o.use_distance_field = on;
  return o;
}

}  // namespace

TEST(CollisionField, DecisionsEqualTheExactPathOnRandomPoses) {
  Tally total;
  std::uint64_t seed = 1;
  for (const char* spec : {"barrett/barrett.json", "parallel_jaw/parallel_jaw.json"}) {
    const Hand hand = Hand::load(model(spec));
    for (const char* name : {"box", "mug", "flask"}) {
      const Mesh target = load_mesh(model(std::string("targets/") + name + ".stl"));
      const Mask paint = load_paint(model(std::string("targets/") + name + ".paint.json"), target);
      // A table slab under the target, touching its base.
      const Vector3d lo = target.bounds.min(), hi = target.bounds.max();
      const std::vector<Obstacle> table = {
          {"table", testing_meshes::box_mesh(Vector3d(lo.x() - 0.1, lo.y() - 0.1, lo.z() - 0.02),
                                             Vector3d(hi.x() + 0.1, hi.y() + 0.1, lo.z()), 2, "table")}};
      struct Variant {
        const char* what;
        Mask free;
        std::vector<Obstacle> obstacles;
      };
      for (const Variant& v : {Variant{"plain", Mask(), {}}, Variant{"paint", paint, {}},
                               Variant{"paint + table", paint, table}}) {
        SCOPED_TRACE(std::string(spec) + " on " + name + ", " + v.what);
        const GraspChecker exact(hand, target, v.free, v.obstacles, with_field(false));
        const GraspChecker field(hand, target, v.free, v.obstacles, with_field(true));
        const Poses p = random_poses(hand, target, testing_scale::cases(200), seed++, field);
        Tally t;
        compare(exact, field, p, (seed % 2) == 0, t);
        std::printf("%-30s %-6s %-14s %4d poses: %3d pruned, %3d penetrating, %3d occluded, %3d obstacle, %3d colliding; %d differ\n",
                    spec, name, v.what, t.poses, t.pruned, t.penetrating, t.occluded, t.obstacle, t.colliding, t.differing);
        total.poses += t.poses;
        total.differing += t.differing;
      }
    }
  }
  std::printf("%d poses, %d with a differing decision\n", total.poses, total.differing);
  EXPECT_EQ(total.differing, 0);
}

// Closing and contacts through the fields against the exact path: on random poses of both
// hands near every bundled target (the open hand's poses that the exact check keeps, and
// near-contact poses), find_contacts gives the same contacts at the start and at the exactly
// closed DOFs, and close_fingers the same reasons; its steps follow the field's lower bounds, so
// it may stop elsewhere within half the gap, but where it stops is where the exact closing stops
// too (closing exactly from the field's DOFs moves nothing), with the exact clearance.
TEST(CollisionField, ClosingAndContactsEqualTheExactPath) {
  int closings = 0, contact_sets = 0, with_contacts = 0;
  std::uint64_t seed = 100;
  for (const char* spec : {"barrett/barrett.json", "parallel_jaw/parallel_jaw.json"}) {
    const Hand hand = Hand::load(model(spec));
    for (const char* name : {"box", "mug", "flask"}) {
      SCOPED_TRACE(std::string(spec) + " on " + name);
      const Mesh target = load_mesh(model(std::string("targets/") + name + ".stl"));
      const Mask paint = load_paint(model(std::string("targets/") + name + ".paint.json"), target);
      const GraspChecker exact(hand, target, paint, {}, with_field(false));
      const GraspChecker field(hand, target, paint, {}, with_field(true));
      const Poses p = random_poses(hand, target, testing_scale::cases(48), seed++, field);
      for (std::size_t k = 0; k < p.wrists.size(); ++k) {
        SCOPED_TRACE("pose " + std::to_string(k));
        const Contacts ca = find_contacts(exact, p.wrists[k], p.dofs[k]);
        const Contacts cb = find_contacts(field, p.wrists[k], p.dofs[k]);
        ++contact_sets;
        with_contacts += ca.points.rows() > 0;
        EXPECT_EQ(ca.points, cb.points);
        EXPECT_EQ(ca.target_points, cb.target_points);
        EXPECT_EQ(ca.distances, cb.distances);
        EXPECT_EQ(ca.faces, cb.faces);
        EXPECT_EQ(ca.links, cb.links);
        EXPECT_EQ(ca.occluded_count, cb.occluded_count);
        // Closing from the open hand (the DOFs at their lower third) at the same wrist.
        Eigen::VectorXd open = hand.dof_lower() + 0.33 * (p.dofs[k] - hand.dof_lower());
        const CloseResult a = close_fingers(exact, p.wrists[k], open);
        const CloseResult b = close_fingers(field, p.wrists[k], open);
        ++closings;
        EXPECT_EQ(a.reasons, b.reasons);
        EXPECT_EQ(a.start_penetrating, b.start_penetrating);
        const CloseResult again = close_fingers(exact, p.wrists[k], b.dofs);
        for (Eigen::Index d = 0; d < b.dofs.size(); ++d) {
          if (b.reasons[d] != StopReason::Contact && b.reasons[d] != StopReason::Limit) continue;
          EXPECT_EQ(again.dofs[d], b.dofs[d]) << "DOF " << d;
          EXPECT_EQ(again.reasons[d], b.reasons[d]) << "DOF " << d;
          EXPECT_NEAR(again.clearance[d], b.clearance[d], 1e-12) << "DOF " << d;
          if (b.reasons[d] == StopReason::Contact) EXPECT_LE(b.clearance[d], 0.5 * exact.options().contact_gap);
        }
        const Contacts da = find_contacts(exact, p.wrists[k], a.dofs);
        const Contacts db = find_contacts(field, p.wrists[k], a.dofs);
        ++contact_sets;
        with_contacts += da.points.rows() > 0;
        EXPECT_EQ(da.points, db.points);
        EXPECT_EQ(da.distances, db.distances);
        EXPECT_EQ(da.faces, db.faces);
        EXPECT_EQ(da.links, db.links);
        EXPECT_EQ(da.occluded_count, db.occluded_count);
      }
    }
  }
  std::printf("%d closings, %d contact sets (%d with contacts) compared\n", closings, contact_sets, with_contacts);
  EXPECT_GT(with_contacts, contact_sets / 10);
}

// The closing's distance through the field (GraspChecker::Impl::link_clearance) against FCL's
// exact distance on random near-contact poses of the Barrett hand: either the exact value, or,
// flagged inexact, a lower bound of it beyond the threshold asked about.
TEST(CollisionField, ClearanceIsExactOrALowerBoundBeyondTheThreshold) {
  const Hand hand = Hand::load(model("barrett/barrett.json"));
  int compared = 0, bounds = 0, exact_values = 0;
  std::uint64_t seed = 300;
  for (const char* name : {"box", "mug", "flask"}) {
    SCOPED_TRACE(name);
    const Mesh target = load_mesh(model(std::string("targets/") + name + ".stl"));
    const GraspChecker field(hand, target, Mask(), {}, with_field(true));
    const detail::CheckerAccess::Impl& I = detail::CheckerAccess::impl(field);
    const Poses p = random_poses(hand, target, testing_scale::cases(48), seed++, field);
    for (std::size_t k = 0; k < p.wrists.size(); ++k) {
      const std::vector<Pose> poses = I.target_frame_poses(p.wrists[k], p.dofs[k]);
      for (std::size_t l = 0; l < poses.size(); ++l)
        for (bool active : {false, true}) {
          if (active && !hand.links()[l].active()) continue;
          const double truth = I.link_distance(static_cast<int>(l), poses[l], active);
          for (double above : {0.0005, 0.002, 0.01}) {
            SCOPED_TRACE("pose " + std::to_string(k) + ", link " + std::to_string(l) + ", above " +
                         std::to_string(above));
            bool exact = false;
            const double d = I.link_clearance(static_cast<int>(l), poses[l], active, above, &exact);
            ++compared;
            if (exact) {
              ++exact_values;
              EXPECT_EQ(d, truth);
            } else {
              ++bounds;
              EXPECT_GT(d, above);
              EXPECT_LE(d, truth + 1e-12);
            }
          }
        }
    }
  }
  std::printf("%d clearances: %d exact, %d lower bounds\n", compared, exact_values, bounds);
  EXPECT_GT(bounds, compared / 4);
  EXPECT_GT(exact_values, compared / 20);
}

TEST(CollisionField, ConvexAndNonConvexLinksAndTheFieldSize) {
  const Mesh target = load_mesh(model("targets/mug.stl"));
  const GraspChecker field(Hand::load(model("parallel_jaw/parallel_jaw.json")), target);
  EXPECT_GT(field.distance_field_bytes(), 100000u);
  EXPECT_LT(field.distance_field_bytes(), 64u << 20);
  EXPECT_GT(field.distance_field_seconds(), 0.0);
  const GraspChecker exact(Hand::load(model("parallel_jaw/parallel_jaw.json")), target, Mask(), {}, with_field(false));
  EXPECT_EQ(exact.distance_field_bytes(), 0u);
  EXPECT_THROW(GraspChecker(Hand::load(model("parallel_jaw/parallel_jaw.json")), target, Mask(), {},
                            [] { CheckOptions o; o.field_cell = 0.0; return o; }()),
               std::invalid_argument);
}

namespace {

// The target less the faces whose centroid lies in its top tenth: an open mesh (a cup without
// its lid), whose field is unsigned.
Mesh without_top(const Mesh& m) {
  const double cut = m.bounds.max().z() - 0.1 * m.bounds.sizes().z();
  std::vector<int> keep;
  for (int f = 0; f < m.faces.rows(); ++f) {
    double z = 0.0;
    for (int k = 0; k < 3; ++k) z += m.vertices(m.faces(f, k), 2) / 3.0;
    if (z < cut) keep.push_back(f);
  }
  Triangles t(static_cast<Eigen::Index>(keep.size()), 3);
  for (std::size_t i = 0; i < keep.size(); ++i) t.row(static_cast<Eigen::Index>(i)) = m.faces.row(keep[i]);
  return make_mesh(m.vertices, t, m.source + " without its top");
}

}  // namespace

// An open target has an unsigned field, which bounds clearances (closing) but decides nothing
// that needs a side: the checks equal the exact path's, and every clearance is the exact distance
// or a lower bound beyond the threshold asked about.
TEST(CollisionField, AnOpenTargetsUnsignedFieldBoundsClearancesOnly) {
  const Hand hand = Hand::load(model("barrett/barrett.json"));
  int compared = 0, bounds = 0;
  std::uint64_t seed = 400;
  for (const char* name : {"mug", "flask"}) {
    SCOPED_TRACE(name);
    const Mesh target = without_top(load_mesh(model(std::string("targets/") + name + ".stl")));
    ASSERT_FALSE(target.closed);
    const GraspChecker exact(hand, target, Mask(), {}, with_field(false));
    const GraspChecker field(hand, target, Mask(), {}, with_field(true));
    const detail::CheckerAccess::Impl& I = detail::CheckerAccess::impl(field);
    ASSERT_TRUE(I.scene[0].field);
    EXPECT_FALSE(I.scene[0].field->is_signed());
    const Poses p = random_poses(hand, target, testing_scale::cases(48), seed++, field);
    Tally t;
    compare(exact, field, p, true, t);
    EXPECT_EQ(t.differing, 0);
    for (std::size_t k = 0; k < p.wrists.size(); ++k) {
      const std::vector<Pose> poses = I.target_frame_poses(p.wrists[k], p.dofs[k]);
      for (std::size_t l = 0; l < poses.size(); ++l) {
        const double truth = I.link_distance(static_cast<int>(l), poses[l], false);
        for (double above : {0.0005, 0.002, 0.01}) {
          bool exact_value = false;
          const double d = I.link_clearance(static_cast<int>(l), poses[l], false, above, &exact_value);
          ++compared;
          if (exact_value) {
            EXPECT_EQ(d, truth);
          } else {
            ++bounds;
            EXPECT_GT(d, above);
            EXPECT_LE(d, truth + 1e-12);
          }
        }
      }
    }
  }
  std::printf("%d clearances on open targets, %d lower bounds\n", compared, bounds);
  EXPECT_GT(bounds, compared / 4);
}

// A target split by free_surface() (resting on a plane: its faces divided along the covered
// strip) checked with the FCL model of the mesh as given decides as the split mesh itself does,
// and measures the same distances: the same surface in fewer faces.
TEST(CollisionField, ASplitTargetCheckedWithTheGivenGeometryDecidesAsTheSplitMesh) {
  const Hand hand = Hand::load(model("barrett/barrett.json"));
  std::uint64_t seed = 500;
  int distances = 0;
  for (const char* name : {"box", "mug", "flask"}) {
    SCOPED_TRACE(name);
    const Mesh given = load_mesh(model(std::string("targets/") + name + ".stl"));
    Occlusion o;
    o.support = SupportPlane::below(given);
    const FreeSurface surface = free_surface(given, o, 0.0025);
    ASSERT_GT(surface.split_faces, 0);
    ASSERT_GT(surface.mesh.faces.rows(), given.faces.rows());
    const std::vector<Obstacle> table = {{"support", support_box(*o.support, given, 0.05)}};
    for (bool on : {false, true}) {
      const GraspChecker split(hand, surface.mesh, surface.free, table, with_field(on));
      const GraspChecker coarse(hand, surface, given, table, with_field(on));
      const Poses p = random_poses(hand, surface.mesh, testing_scale::cases(48), seed++, split);
      Tally t;
      compare(split, coarse, p, true, t);
      EXPECT_EQ(t.differing, 0);
      const detail::CheckerAccess::Impl &A = detail::CheckerAccess::impl(split), &B = detail::CheckerAccess::impl(coarse);
      for (std::size_t k = 0; k < p.wrists.size(); ++k) {
        const std::vector<Pose> poses = A.target_frame_poses(p.wrists[k], p.dofs[k]);
        for (std::size_t l = 0; l < poses.size(); ++l, ++distances)
          EXPECT_NEAR(A.link_distance(static_cast<int>(l), poses[l], false),
                      B.link_distance(static_cast<int>(l), poses[l], false), 1e-9);
      }
    }
    // Not split from this mesh: refused, naming the argument.
    const Mesh other = load_mesh(model("targets/mug.stl"));
    if (std::string(name) != "mug") {
      try {
        GraspChecker(hand, surface, other, table);
        ADD_FAILURE() << "a surface split from another mesh was accepted";
      } catch (const std::invalid_argument& e) {
        EXPECT_EQ(std::string(e.what()).rfind("surface: ", 0), 0u) << e.what();
      }
    }
  }
  std::printf("%d link distances compared\n", distances);
}
