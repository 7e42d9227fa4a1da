// Hands: URDF + spec loading, forward kinematics against hand-computed trigonometry from the
// models' stated dimensions, joint limits, mimic joints, constellations and spec errors.
#include <gtest/gtest.h>

#include <pairgrasp/error.hpp>
#include <pairgrasp/hand.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <set>
#include <stdexcept>
#include <thread>

#include <unistd.h>

namespace fs = std::filesystem;
using namespace pairgrasp;
using Eigen::Vector3d;

namespace {

const std::string kModels = PAIRGRASP_MODEL_DIR;
const std::string kBarrett = kModels + "/barrett/barrett.json";
const std::string kJaw = kModels + "/parallel_jaw/parallel_jaw.json";
constexpr double kPi = 3.14159265358979323846;

// Barrett BH8-28x dimensions as stated in models/README.md (metres, radians).
constexpr double kPalmTop = 0.075, kBaseX = 0.025, kKnuckle = 0.050, kKnuckleHeight = 0.020;
constexpr double kProx = 0.070, kDist = 0.055, kProxHalfThick = 0.009, kDistHalfThick = 0.008;
constexpr double kWidth = 0.025, kPalmRadius = 0.048;
const double kRest = 42.0 * kPi / 180.0;

/// One Barrett finger computed by hand: yaw of its knuckle about z (finger 1: -spread,
/// finger 2: +spread, finger 3: pi), radial unit u from the knuckle axis to the proximal joint.
struct FingerByHand {
  Vector3d joint, u, d1, d2, dist_joint;
  double theta, phi;
  FingerByHand(int finger, double spread, double flex) {
    const Vector3d base = finger == 1 ? Vector3d(kBaseX, 0, kPalmTop)
                          : finger == 2 ? Vector3d(-kBaseX, 0, kPalmTop)
                                        : Vector3d(0, 0, kPalmTop);
    const double yaw = finger == 1 ? -spread : finger == 2 ? spread : kPi;
    u = Vector3d(-std::sin(yaw), std::cos(yaw), 0);
    const Vector3d z = Vector3d::UnitZ();
    joint = base + kKnuckle * u + kKnuckleHeight * z;
    theta = flex;
    phi = flex + kRest + flex / 3.0;  // distal: rest bend + a third of the flexion
    d1 = std::cos(theta) * z - std::sin(theta) * u;  // curls towards the palm centre (-u)
    d2 = std::cos(phi) * z - std::sin(phi) * u;
    dist_joint = joint + kProx * d1;
  }
  Vector3d tip() const { return dist_joint + kDist * d2; }
  // Inner (palm-facing) normals: -(cos a * u + sin a * z), a the link's angle from +z.
  Vector3d prox_normal() const { return -(std::cos(theta) * u + std::sin(theta) * Vector3d::UnitZ()); }
  Vector3d dist_normal() const { return -(std::cos(phi) * u + std::sin(phi) * Vector3d::UnitZ()); }
  Vector3d prox_sample() const { return joint + 0.5 * kProx * d1 + kProxHalfThick * prox_normal(); }
  Vector3d dist_sample() const { return dist_joint + 0.5 * kDist * d2 + kDistHalfThick * dist_normal(); }
};

Eigen::VectorXd vec(std::initializer_list<double> v) {
  Eigen::VectorXd out(static_cast<Eigen::Index>(v.size()));
  Eigen::Index i = 0;
  for (double x : v) out[i++] = x;
  return out;
}

const Hand& barrett() {
  static const Hand hand = Hand::load(kBarrett);
  return hand;
}

/// A scratch directory, removed at the end of the test.
struct TempDir {
  fs::path path;
  TempDir() {
    static std::atomic<int> counter{0};
    path = fs::temp_directory_path() /
           ("pairgrasp_hand_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string write(const std::string& name, const std::string& text) const {
    const fs::path p = path / name;
    fs::create_directories(p.parent_path());
    std::ofstream(p) << text;
    return p.string();
  }
};

/// The Barrett spec text with one substitution (the URDF named by absolute path).
std::string barrett_spec(const std::function<void(std::string&)>& edit = nullptr) {
  std::ifstream in(kBarrett);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto replace = [&](const std::string& from, const std::string& to) {
    const auto at = text.find(from);
    if (at == std::string::npos) throw std::runtime_error("test spec lacks: " + from);
    text.replace(at, from.size(), to);
  };
  replace("\"urdf\": \"bh8_28x.urdf\"", "\"urdf\": \"" + kModels + "/barrett/bh8_28x.urdf\"");
  replace("\"package_paths\": [\"..\"]", "\"package_paths\": [\"" + kModels + "\"]");
  if (edit) edit(text);
  return text;
}

void replace_in(std::string& text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  if (at == std::string::npos) throw std::runtime_error("test spec lacks: " + from);
  text.replace(at, from.size(), to);
}

/// Expects Hand::load(spec) to throw FileError whose message holds every needle.
void expect_file_error(const std::string& spec, const std::vector<std::string>& needles,
                       const HandLoadOptions& options = {}) {
  try {
    Hand::load(spec, options);
    ADD_FAILURE() << "no error for " << spec << " (expected: " << needles.front() << ")";
  } catch (const FileError& e) {
    const std::string what = e.what();
    for (const auto& n : needles) EXPECT_NE(what.find(n), std::string::npos) << "'" << n << "' not in: " << what;
  }
}

double distance_to_triangle(const Vector3d& p, const Vector3d& a, const Vector3d& b, const Vector3d& c) {
  // Brute force: the plane distance when the projection is inside, else the nearest edge point.
  const Vector3d n = (b - a).cross(c - a).normalized();
  const Vector3d q = p - n.dot(p - a) * n;
  const auto inside = [&](const Vector3d& x, const Vector3d& y) { return n.dot((y - x).cross(q - x)) >= -1e-15; };
  if (inside(a, b) && inside(b, c) && inside(c, a)) return std::abs(n.dot(p - a));
  double best = 1e9;
  const Vector3d v[3] = {a, b, c};
  for (int k = 0; k < 3; ++k) {
    const Vector3d e = v[(k + 1) % 3] - v[k];
    const double t = std::clamp(e.dot(p - v[k]) / e.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (v[k] + t * e - p).norm());
  }
  return best;
}

}  // namespace

// ------------------------------------------------------------------------------- loading

TEST(HandLoad, BarrettModelMatchesItsSpec) {
  const Hand& h = barrett();
  EXPECT_EQ(h.name(), "barrett_bh8_28x");
  EXPECT_EQ(h.wrist_link(), "bh_palm");
  EXPECT_EQ(h.dof_names(), (std::vector<std::string>{"spread", "f1_flex", "f2_flex", "f3_flex"}));
  EXPECT_NEAR(h.dof_lower()[0], 0.0, 1e-12);
  EXPECT_FALSE(std::signbit(h.dof_lower()[0]));  // 0, not -0 (URDF limit 0 through ratio -1)
  EXPECT_NEAR(h.dof_upper()[0], kPi, 1e-12);  // from the URDF limits through ratios -1 and +1
  for (int i = 1; i < 4; ++i) {
    EXPECT_NEAR(h.dof_lower()[i], 0.0, 1e-12);
    EXPECT_NEAR(h.dof_upper()[i], 2.44, 1e-12);
    EXPECT_NEAR(h.dof_step()[i], 0.25, 1e-12);
  }
  EXPECT_TRUE(h.approach().isApprox(Vector3d::UnitZ()));
  EXPECT_EQ(h.link_names().front(), "bh_palm");  // the wrist link is the hand's root
  EXPECT_EQ(h.joint_names().size(), 8u);  // 2 spread + 3 flexion + 3 distal mimics
  EXPECT_EQ(h.links().size(), 10u);       // palm, 3 knuckles, 3 proximal, 3 distal
  int active = 0;
  for (const auto& l : h.links()) active += l.active();
  EXPECT_EQ(active, 7);
  EXPECT_EQ(h.link_index("bh_palm"), 0);
  EXPECT_EQ(h.link_index("no_such_link"), -1);
}

TEST(HandLoad, LinkGeometryHasTheStatedDimensions) {
  const Hand& h = barrett();
  // Palm: COLLADA authored in millimetres with <unit meter="0.001">, found through package://.
  const Mesh& palm = h.links()[h.link_index("bh_palm")].mesh;
  EXPECT_TRUE(palm.closed);
  EXPECT_NEAR(palm.bounds.min().z(), 0.0, 1e-9);
  EXPECT_NEAR(palm.bounds.max().z(), kPalmTop, 1e-9);
  EXPECT_NEAR(palm.bounds.max().head<2>().norm(), kPalmRadius * std::cos(kPi / 24) * std::sqrt(2.0), 2e-3);
  // Distal link: an STL in millimetres scaled by the URDF's <mesh scale="0.001 ...">.
  const Mesh& dist = h.links()[h.link_index("bh_f1_dist")].mesh;
  EXPECT_NEAR(dist.bounds.max().z(), kDist, 1e-9);
  EXPECT_NEAR(dist.bounds.max().x() - dist.bounds.min().x(), kWidth, 1e-9);
  EXPECT_NEAR(dist.volume, kWidth * 2 * kDistHalfThick * kDist, 1e-12);
  // Finger 3's knuckle: a URDF <box> primitive moved by its geometry <origin>.
  const Mesh& k3 = h.links()[h.link_index("bh_f3_knuckle")].mesh;
  EXPECT_NEAR(k3.bounds.min().y(), -kWidth / 2, 1e-12);
  EXPECT_NEAR(k3.bounds.max().y(), kKnuckle + kWidth / 2, 1e-12);
  EXPECT_NEAR(k3.bounds.min().z(), 0.0, 1e-12);
  EXPECT_TRUE(k3.closed);
  // Finger 1's knuckle has visual geometry only: used as the fallback.
  EXPECT_EQ(h.links()[h.link_index("bh_f1_knuckle")].mesh.faces.rows(), 12);
}

TEST(HandLoad, ParallelJawLoads) {
  const Hand h = Hand::load(kJaw);
  EXPECT_EQ(h.dof_names(), std::vector<std::string>{"opening"});
  EXPECT_NEAR(h.dof_lower()[0], 0.0, 1e-12);
  EXPECT_NEAR(h.dof_upper()[0], 0.08, 1e-12);  // 2 x the 0.04 m finger stroke (ratio 0.5)
  EXPECT_TRUE(h.dofs()[0].linear);
  EXPECT_EQ(h.joint_names(), (std::vector<std::string>{"pj_left_joint", "pj_right_joint"}));
}

// ------------------------------------------------------------------------------- kinematics

TEST(HandLoad, JointsListTheUrdfTree) {
  const Hand h = Hand::load(kBarrett);
  const auto joints = h.joints();
  ASSERT_EQ(joints.size(), 9u);  // 10 links: one parent joint each but the palm's
  const auto links = h.link_names();
  for (std::size_t k = 0; k < joints.size(); ++k) EXPECT_EQ(joints[k].child_link, links[k + 1]);
  int fixed = 0, mimics = 0;
  for (const auto& j : joints) {
    fixed += j.type == HandJoint::Type::Fixed;
    if (!j.mimic_joint.empty()) {
      ++mimics;
      EXPECT_NEAR(j.multiplier, 1.0 / 3.0, 1e-12) << j.name;
    }
    if (j.type == HandJoint::Type::Revolute) EXPECT_EQ(j.effort, 5.0) << j.name;
  }
  EXPECT_EQ(fixed, 1);   // finger 3's knuckle
  EXPECT_EQ(mimics, 3);  // the distal joints
  const auto& j12 = joints[1];
  EXPECT_EQ(j12.name, "bh_j12");
  EXPECT_EQ(j12.parent_link, "bh_f1_knuckle");
  EXPECT_TRUE(j12.origin.translation().isApprox(Vector3d(0, kKnuckle, kKnuckleHeight)));
  EXPECT_TRUE(j12.axis.isApprox(Vector3d::UnitX()));
  EXPECT_EQ(j12.lower, 0.0);
  EXPECT_EQ(j12.upper, 2.44);
  EXPECT_FALSE(h.inertial("bh_palm").present);
  EXPECT_THROW(h.inertial("no_such_link"), std::invalid_argument);
}

TEST(HandKinematics, FingertipsMatchHandComputation) {
  const Hand& h = barrett();
  const double tip_z = h.links()[h.link_index("bh_f1_dist")].mesh.bounds.max().z();  // the tip face
  ASSERT_NEAR(tip_z, kDist, 1e-9);
  const std::vector<Eigen::VectorXd> samples = {vec({0, 0, 0, 0}),         vec({kPi / 2, 1.0, 0.5, 2.0}),
                                                vec({kPi, 2.44, 1.2, 0.3}), vec({0.7, 0.3, 2.2, 1.5}),
                                                vec({2.9, 1.7, 0.05, 2.44})};
  for (const auto& d : samples) {
    const auto T = h.link_transforms(d);
    for (int f = 1; f <= 3; ++f) {
      const FingerByHand by_hand(f, d[0], d[f]);
      const Vector3d tip = T.at("bh_f" + std::to_string(f) + "_dist") * Vector3d(0, 0, tip_z);
      EXPECT_LT((tip - by_hand.tip()).norm(), 1e-9) << "finger " << f << " at " << d.transpose();
      const Vector3d joint = T.at("bh_f" + std::to_string(f) + "_prox").translation();
      EXPECT_LT((joint - by_hand.joint).norm(), 1e-9);
    }
  }
  // At rest every proximal link points straight up (+z).
  const auto T0 = barrett().link_transforms(vec({0, 0, 0, 0}));
  for (int f = 1; f <= 3; ++f)
    EXPECT_TRUE((T0.at("bh_f" + std::to_string(f) + "_prox").linear() * Vector3d::UnitZ()).isApprox(Vector3d::UnitZ()));
}

TEST(HandKinematics, DistalJointsMimicOneThirdOfTheProximal) {
  const Hand& h = barrett();
  const auto names = h.joint_names();
  auto at = [&](const std::string& n) { return std::find(names.begin(), names.end(), n) - names.begin(); };
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> flex(0, 2.44), spread(0, kPi);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::VectorXd d = vec({spread(rng), flex(rng), flex(rng), flex(rng)});
    const Eigen::VectorXd q = h.joint_values(d);
    ASSERT_EQ(q.size(), 8);
    for (int f = 1; f <= 3; ++f) {
      const std::string p = "bh_j" + std::to_string(f);
      EXPECT_NEAR(q[at(p + "2")], d[f], 1e-12);
      EXPECT_NEAR(q[at(p + "3")], d[f] / 3.0, 1e-12);
    }
    EXPECT_NEAR(q[at("bh_j11")], -d[0], 1e-12);
    EXPECT_NEAR(q[at("bh_j21")], d[0], 1e-12);
  }
}

TEST(HandKinematics, SpreadMovesTheTwoSpreadingFingersAsMirrorImages) {
  const Hand& h = barrett();
  for (double spread : {kPi / 2, 0.4, 2.5}) {
    const auto T = h.link_transforms(vec({spread, 1.1, 1.1, 0.0}));
    for (const std::string part : {"_knuckle", "_prox", "_dist"}) {
      const Vector3d p1 = T.at("bh_f1" + part) * Vector3d(0.003, 0.01, 0.02);
      const Vector3d p2 = T.at("bh_f2" + part) * Vector3d(-0.003, 0.01, 0.02);  // mirrored local point
      EXPECT_NEAR(p1.x(), -p2.x(), 1e-12) << part;
      EXPECT_NEAR(p1.y(), p2.y(), 1e-12) << part;
      EXPECT_NEAR(p1.z(), p2.z(), 1e-12) << part;
    }
  }
  // At spread pi/2 the spreading fingers' proximal joints sit on the x axis, 0.075 m out.
  const auto T = h.link_transforms(vec({kPi / 2, 0, 0, 0}));
  EXPECT_LT((T.at("bh_f1_prox").translation() - Vector3d(kBaseX + kKnuckle, 0, kPalmTop + kKnuckleHeight)).norm(), 1e-12);
  EXPECT_LT((T.at("bh_f2_prox").translation() - Vector3d(-kBaseX - kKnuckle, 0, kPalmTop + kKnuckleHeight)).norm(), 1e-12);
}

TEST(HandKinematics, BadDofVectorsThrowNamingTheDof) {
  const Hand& h = barrett();
  auto expect_invalid = [&](const Eigen::VectorXd& d, const std::vector<std::string>& needles, bool clamp = false) {
    try {
      h.joint_values(d, clamp);
      ADD_FAILURE() << "accepted " << d.transpose();
    } catch (const std::invalid_argument& e) {
      for (const auto& n : needles) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what();
    }
  };
  expect_invalid(vec({3.2, 0, 0, 0}), {"spread", "3.141592654", "outside"});
  expect_invalid(vec({0, 0, 0, 2.5}), {"f3_flex", "2.44"});
  expect_invalid(vec({0, -0.01, 0, 0}), {"f1_flex"});
  expect_invalid(vec({0, std::nan(""), 0, 0}), {"f1_flex", "not finite"});
  expect_invalid(vec({0, std::nan(""), 0, 0}), {"f1_flex"}, true);  // clamping cannot fix NaN
  expect_invalid(vec({0, 0, 0}), {"dofs: expected 4, got 3"});
  expect_invalid(vec({0, 0, 0, 0, 0}), {"dofs: expected 4, got 5"});
  EXPECT_THROW(h.link_transforms(vec({0, 0, 3, 0})), std::invalid_argument);
  EXPECT_THROW(h.constellation(vec({0, 0, 3, 0}), ConstellationMode::PerLink), std::invalid_argument);
  // Within a tiny epsilon of a limit is accepted (and held at the limit).
  EXPECT_NO_THROW(h.joint_values(vec({kPi + 1e-12, 2.44 + 1e-12, -1e-12, 0})));
}

TEST(HandKinematics, ClampHoldsValuesAtTheirLimits) {
  const Hand& h = barrett();
  const Eigen::VectorXd clamped = h.joint_values(vec({4.0, -1.0, 3.0, 1.0}), true);
  const Eigen::VectorXd inside = h.joint_values(vec({kPi, 0.0, 2.44, 1.0}));
  EXPECT_TRUE(clamped.isApprox(inside, 1e-15));
  const auto T = h.link_transforms(vec({-5.0, 9.0, 1.0, 1.0}), true);
  const FingerByHand f1(1, 0.0, 2.44);
  EXPECT_LT((T.at("bh_f1_dist") * Vector3d(0, 0, kDist) - f1.tip()).norm(), 1e-9);
}

// ------------------------------------------------------------------------------- constellations

TEST(HandConstellation, PerLinkBarrettHasSevenOutwardSamples) {
  const Hand& h = barrett();
  for (const auto& d : {vec({0, 0, 0, 0}), vec({1.0, 1.2, 0.4, 2.3}), vec({kPi, 2.44, 2.44, 2.44})}) {
    const Constellation c = h.constellation(d, ConstellationMode::PerLink);
    ASSERT_EQ(c.points.rows(), 7);
    ASSERT_EQ(c.link_names.size(), 7u);
    EXPECT_EQ(c.link_names, (std::vector<std::string>{"bh_palm", "bh_f1_prox", "bh_f1_dist", "bh_f2_prox",
                                                       "bh_f2_dist", "bh_f3_prox", "bh_f3_dist"}));
    for (int i = 0; i < 7; ++i) EXPECT_NEAR(c.normals.row(i).norm(), 1.0, 1e-12);
    // Palm: the centre of the top face, facing +z (the approach direction).
    EXPECT_LT((c.points.row(0).transpose() - Vector3d(0, 0, kPalmTop)).norm(), 1e-7);
    EXPECT_LT((c.normals.row(0).transpose() - Vector3d::UnitZ()).norm(), 1e-12);
    for (int f = 1; f <= 3; ++f) {
      const FingerByHand by_hand(f, d[0], d[f]);
      const int p = 2 * f - 1, q = 2 * f;
      // Mesh coordinates come from float32 STL files: 0.1 micrometre tolerance.
      EXPECT_LT((c.points.row(p).transpose() - by_hand.prox_sample()).norm(), 1e-7) << "finger " << f;
      EXPECT_LT((c.normals.row(p).transpose() - by_hand.prox_normal()).norm(), 1e-7) << "finger " << f;
      EXPECT_LT((c.points.row(q).transpose() - by_hand.dist_sample()).norm(), 1e-7) << "finger " << f;
      EXPECT_LT((c.normals.row(q).transpose() - by_hand.dist_normal()).norm(), 1e-7) << "finger " << f;
      // Outward: the normal points away from the link's own centre (out of the finger).
      const auto T = h.link_transforms(d);
      const Vector3d centre = T.at("bh_f" + std::to_string(f) + "_prox") * Vector3d(0, 0, kProx / 2);
      EXPECT_GT(c.normals.row(p).dot(c.points.row(p) - centre.transpose()), 0.0);
    }
  }
  // At rest, finger 3 (at y = -0.05) faces the palm centre: +y.
  const Constellation c = h.constellation(vec({0, 0, 0, 0}), ConstellationMode::PerLink);
  EXPECT_LT((c.normals.row(5).transpose() - Vector3d::UnitY()).norm(), 1e-12);
}

TEST(HandConstellation, AreaSamplesLieOnActiveFacesAndScaleWithSpacing) {
  const Hand& h = barrett();
  const Eigen::VectorXd d = vec({0.8, 0.9, 1.6, 0.4});
  const auto poses = h.link_poses(d);
  // Active area from the stated dimensions: a 24-gon palm top of circumradius 0.048 and the
  // inner faces of three proximal (0.025 x 0.070) and three distal (0.025 x 0.055) links.
  const double area = 12 * kPalmRadius * kPalmRadius * std::sin(2 * kPi / 24) + 3 * kWidth * (kProx + kDist);
  long counts[2];
  const double spacings[2] = {0.01, 0.005};
  for (int s = 0; s < 2; ++s) {
    const Constellation c = h.constellation(d, ConstellationMode::Area, spacings[s]);
    counts[s] = c.points.rows();
    EXPECT_GT(counts[s], 0.5 * area / (spacings[s] * spacings[s]));
    EXPECT_LT(counts[s], 4.0 * area / (spacings[s] * spacings[s]));
    std::set<std::string> seen;
    for (Eigen::Index i = 0; i < c.points.rows(); ++i) {
      const HandLink& link = h.links()[c.link[i]];
      seen.insert(link.name);
      ASSERT_TRUE(link.active());
      const Vector3d p = poses[c.link[i]].inverse() * c.points.row(i).transpose();
      const Vector3d n = poses[c.link[i]].linear().transpose() * c.normals.row(i).transpose();
      double best = 1e9;
      int best_face = -1;
      for (int f : link.active_faces) {
        const double dist = distance_to_triangle(p, link.mesh.vertices.row(link.mesh.faces(f, 0)),
                                                 link.mesh.vertices.row(link.mesh.faces(f, 1)),
                                                 link.mesh.vertices.row(link.mesh.faces(f, 2)));
        if (dist < best) best = dist, best_face = f;
      }
      ASSERT_LT(best, 1e-9) << "sample " << i << " of " << link.name << " is off its active surface";
      EXPECT_GT(n.dot(link.mesh.face_normal(best_face)), 1 - 1e-9);
    }
    EXPECT_EQ(seen.size(), 7u);
  }
  const double ratio = static_cast<double>(counts[1]) / counts[0];
  EXPECT_GT(ratio, 3.0);
  EXPECT_LT(ratio, 5.5);
  EXPECT_THROW(h.constellation(d, ConstellationMode::Area, 0.0), std::invalid_argument);
  EXPECT_THROW(h.constellation(d, ConstellationMode::Area, -0.01), std::invalid_argument);
  EXPECT_THROW(h.constellation(d, ConstellationMode::Area, std::nan("")), std::invalid_argument);
}

TEST(HandConstellation, AreaModeIsSafeFromSeveralThreads) {
  const Hand h = Hand::load(kBarrett);  // a fresh cache
  const Eigen::VectorXd d = vec({0.3, 0.5, 0.6, 0.7});
  std::vector<Constellation> out(4);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] { out[t] = h.constellation(d, ConstellationMode::Area, 0.007); });
  for (auto& t : threads) t.join();
  for (int t = 1; t < 4; ++t) EXPECT_TRUE(out[t].points == out[0].points);
}

TEST(HandConstellation, ParallelJawPadsFaceEachOtherAndOpenByTheDof) {
  const Hand h = Hand::load(kJaw);
  for (double q : {0.0, 0.03, 0.08}) {
    const Constellation c = h.constellation(vec({q}), ConstellationMode::PerLink);
    ASSERT_EQ(c.points.rows(), 2);
    EXPECT_EQ(c.link_names, (std::vector<std::string>{"pj_left_finger", "pj_right_finger"}));
    // Pads: inner faces 0.020..0.070 above the 0.050 m base top, centred on the gripper's axis.
    EXPECT_LT((c.points.row(0).transpose() - Vector3d(-q / 2, 0, 0.095)).norm(), 1e-7);
    EXPECT_LT((c.points.row(1).transpose() - Vector3d(q / 2, 0, 0.095)).norm(), 1e-7);
    EXPECT_LT((c.normals.row(0).transpose() - Vector3d::UnitX()).norm(), 1e-12);
    EXPECT_LT((c.normals.row(1).transpose() + Vector3d::UnitX()).norm(), 1e-12);
    EXPECT_NEAR((c.points.row(1) - c.points.row(0)).dot(c.normals.row(0)), q, 1e-9);
  }
  // Only the pad faces are active (the box excludes the carriage's parallel inner face).
  for (const auto& l : h.links())
    if (l.active()) {
      for (int f : l.active_faces)
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(l.mesh.vertices(l.mesh.faces(f, k), 0), 0.0, 1e-12);
    }
  const Constellation a = h.constellation(vec({0.05}), ConstellationMode::Area, 0.005);
  EXPECT_GT(a.points.rows(), 2 * 0.5 * (0.02 * 0.05) / (0.005 * 0.005));
  for (Eigen::Index i = 0; i < a.points.rows(); ++i)
    EXPECT_NEAR(std::abs(a.points(i, 0)), 0.025, 1e-7);
}

// ------------------------------------------------------------------------------- URDF features

namespace {
const char* kSmallUrdf = R"(<?xml version="1.0"?>
<robot name="small">
  <link name="base"/>
  <link name="palm">
    <collision><origin xyz="0 0 0.01" rpy="0 0 0"/><geometry><box size="0.04 0.04 0.02"/></geometry></collision>
  </link>
  <link name="a">
    <visual><origin xyz="0 0 0.02" rpy="0 0 0"/><geometry><cylinder radius="0.01" length="0.04"/></geometry></visual>
  </link>
  <link name="b">
    <collision><geometry><sphere radius="0.01"/></geometry></collision>
  </link>
  <link name="c">
    <collision><origin xyz="0 0 0" rpy="0 0 1.5707963267948966"/><geometry><box size="0.1 0.02 0.02"/></geometry></collision>
  </link>
  <link name="d">
    <collision><geometry><mesh filename="PKG_URI" scale="1 1 1"/></geometry></collision>
  </link>
  <joint name="base_to_palm" type="fixed">
    <parent link="base"/><child link="palm"/><origin xyz="0.1 0.2 0.3" rpy="0 0 0.5"/>
  </joint>
  <joint name="j1" type="revolute">
    <parent link="palm"/><child link="a"/><origin xyz="0 0 0.02"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="j2" type="revolute">
    <parent link="a"/><child link="b"/><origin xyz="0 0 0.04"/><axis xyz="1 0 0"/>
    <limit lower="-5" upper="5" effort="1" velocity="1"/>
    <mimic joint="j1" multiplier="2" offset="0.1"/>
  </joint>
  <joint name="j3" type="continuous">
    <parent link="b"/><child link="c"/><origin xyz="0 0 0.02"/><axis xyz="0 1 0"/>
    <mimic joint="j2" multiplier="0.5" offset="-0.2"/>
  </joint>
  <joint name="j4" type="continuous">
    <parent link="palm"/><child link="d"/><origin xyz="0 0.05 0"/><axis xyz="0 0 1"/>
  </joint>
</robot>
)";

std::string small_urdf(const std::string& mesh_uri = "package://barrett/meshes/bh_finger_prox.stl") {
  std::string s = kSmallUrdf;
  replace_in(s, "PKG_URI", mesh_uri);
  return s;
}

const char* kSmallSpec = R"({
  "urdf": "small.urdf",
  "wrist_link": "palm",
  "approach": [0, 0, 2],
  "dofs": [{"name": "bend", "joints": [{"joint": "j1"}]},
           {"name": "turn", "joints": [{"joint": "j4"}]}],
  "active_surfaces": [{"link": "palm", "normal_cone": {"axis": [0, 0, 1], "half_angle_deg": 5}},
                      {"link": "b", "faces": [0, 1, 2]}]
})";
}  // namespace

TEST(HandUrdf, PrimitivesMimicChainsAndTheWristSubtree) {
  TempDir dir;
  dir.write("small.urdf", small_urdf());
  const std::string spec = dir.write("small.json", kSmallSpec);
  HandLoadOptions opt;
  opt.package_paths = {kModels};
  const Hand h = Hand::load(spec, opt);
  EXPECT_EQ(h.name(), "small");  // the URDF's robot name when the spec has none
  EXPECT_TRUE(h.approach().isApprox(Vector3d::UnitZ()));
  // The hand is the wrist's subtree: the URDF root above the wrist (base) is not part of it.
  EXPECT_EQ(h.link_names(), (std::vector<std::string>{"palm", "a", "b", "c", "d"}));
  const auto T = h.link_transforms(vec({0.0, 0.0}));
  EXPECT_TRUE(T.at("palm").isApprox(Pose::Identity()));
  EXPECT_EQ(T.count("base"), 0u);
  // Limits: j1's [-1, 1] and its mimic j2 (2 q + 0.1 in [-5, 5]) leave [-1, 1]; the continuous j4
  // defaults to [-pi, pi].
  EXPECT_NEAR(h.dof_lower()[0], -1.0, 1e-12);
  EXPECT_NEAR(h.dof_upper()[0], 1.0, 1e-12);
  EXPECT_NEAR(h.dof_lower()[1], -kPi, 1e-12);
  EXPECT_NEAR(h.dof_upper()[1], kPi, 1e-12);
  // Mimic chain: j3 = 0.5 (2 q + 0.1) - 0.2 = q - 0.15.
  const Eigen::VectorXd q = h.joint_values(vec({0.4, 0.0}));
  EXPECT_EQ(h.joint_names(), (std::vector<std::string>{"j1", "j2", "j3", "j4"}));
  EXPECT_NEAR(q[1], 0.9, 1e-12);
  EXPECT_NEAR(q[2], 0.25, 1e-12);
  // Primitive geometry: cylinder moved up by its origin, sphere volume, box turned about z.
  const Mesh& cyl = h.links()[h.link_index("a")].mesh;
  EXPECT_NEAR(cyl.bounds.min().z(), 0.0, 1e-12);
  EXPECT_NEAR(cyl.bounds.max().z(), 0.04, 1e-12);
  EXPECT_TRUE(cyl.closed);
  const Mesh& sph = h.links()[h.link_index("b")].mesh;
  EXPECT_NEAR(sph.volume, 4.0 / 3.0 * kPi * 1e-6, 0.03 * 4.0 / 3.0 * kPi * 1e-6);
  const Mesh& box = h.links()[h.link_index("c")].mesh;
  EXPECT_NEAR(box.bounds.max().x() - box.bounds.min().x(), 0.02, 1e-12);
  EXPECT_NEAR(box.bounds.max().y() - box.bounds.min().y(), 0.1, 1e-12);
  EXPECT_EQ(h.links()[h.link_index("b")].active_faces, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(h.link_index("base"), -1);  // no geometry
  // FK by hand: the sphere centre (link b) at q = 0.4 sits 0.04 along the bent cylinder.
  const auto T4 = h.link_transforms(vec({0.4, 0.0}));
  const Vector3d b = Vector3d(0, 0, 0.02) + 0.04 * Vector3d(0, -std::sin(0.4), std::cos(0.4));
  EXPECT_LT((T4.at("b").translation() - b).norm(), 1e-12);
}

// A robot's whole URDF: an arm (two revolute joints, a mesh that does not exist), a flange fixed to
// its last link, the hand (palm, one prismatic finger) fixed to the flange. The palm's material is
// defined nowhere, as in a hand cut out of a robot's URDF: urdfdom tolerates it, and so do we.
const char* kRobotUrdf = R"(<?xml version="1.0"?>
<robot name="arm_and_hand">
  <link name="world"><collision><geometry><mesh filename="no_such_arm_mesh.stl"/></geometry></collision></link>
  <link name="upper"><collision><geometry><cylinder radius="0.03" length="0.3"/></geometry></collision></link>
  <link name="lower"><collision><geometry><cylinder radius="0.03" length="0.3"/></geometry></collision></link>
  <link name="flange"/>
  <link name="palm"><collision><geometry><box size="0.08 0.04 0.02"/></geometry></collision>
    <visual><geometry><box size="0.08 0.04 0.02"/></geometry><material name="defined_nowhere"/></visual></link>
  <link name="finger"><collision><origin xyz="0 0 0.03"/><geometry><box size="0.01 0.02 0.04"/></geometry></collision></link>
  <joint name="shoulder" type="revolute"><parent link="world"/><child link="upper"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="10" velocity="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="lower"/><origin xyz="0 0 0.3"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="10" velocity="1"/></joint>
  <joint name="to_flange" type="fixed"><parent link="lower"/><child link="flange"/><origin xyz="0 0 0.2"/></joint>
  <joint name="to_palm" type="fixed"><parent link="flange"/><child link="palm"/>
    <origin xyz="0 0 0.05" rpy="0 0 0.7"/></joint>
  <joint name="slide" type="prismatic"><parent link="palm"/><child link="finger"/><origin xyz="0.02 0 0.01"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.03" effort="10" velocity="0.1"/>MIMIC</joint>
</robot>
)";

std::string robot_spec(const std::string& wrist) {
  return R"({"urdf": "robot.urdf", "wrist_link": ")" + wrist + R"(", "approach": [0, 0, 1],
  "dofs": [{"name": "open", "joints": [{"joint": "slide"}]}],
  "active_surfaces": [{"link": "finger", "normal_cone": {"axis": [-1, 0, 0], "half_angle_deg": 10}}]})";
}

TEST(HandUrdf, TheHandInsideARobotIsTheWristSubtree) {
  TempDir dir;
  std::string urdf = kRobotUrdf;
  replace_in(urdf, "MIMIC", "");
  dir.write("robot.urdf", urdf);
  // The arm above the wrist is ignored: its joints drive nothing and its missing mesh is not read.
  const Hand h = Hand::load(dir.write("palm.json", robot_spec("palm")));
  EXPECT_EQ(h.link_names(), (std::vector<std::string>{"palm", "finger"}));
  EXPECT_EQ(h.joint_names(), (std::vector<std::string>{"slide"}));
  const auto T = h.link_transforms(vec({0.01}));
  EXPECT_TRUE(T.at("palm").isApprox(Pose::Identity(), 1e-12));
  EXPECT_TRUE(T.at("finger").translation().isApprox(Vector3d(0.03, 0, 0.01), 1e-12));
  // A wrist higher up takes the links below it, with the fixed offsets of the URDF.
  const Hand f = Hand::load(dir.write("flange.json", robot_spec("flange")));
  EXPECT_EQ(f.link_names(), (std::vector<std::string>{"flange", "palm", "finger"}));
  const Pose palm = f.link_transforms(vec({0.0})).at("palm");
  EXPECT_TRUE(palm.translation().isApprox(Vector3d(0, 0, 0.05), 1e-12));
  EXPECT_TRUE(palm.linear().isApprox(Eigen::AngleAxisd(0.7, Vector3d::UnitZ()).toRotationMatrix(), 1e-12));
  // A wrist whose subtree holds an arm joint needs a DOF for it: the error names the joint.
  try {
    Hand::load(dir.write("upper.json", robot_spec("upper")));
    ADD_FAILURE() << "no error for a hand that holds the elbow";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("joint 'elbow'"), std::string::npos) << e.what();
  }
  expect_file_error(dir.write("none.json", robot_spec("gripper")), {"wrist_link", "no link 'gripper'", "robot.urdf"});
  // A hand joint that mimics an arm joint cannot be driven from the hand: named, not followed.
  urdf = kRobotUrdf;
  replace_in(urdf, "MIMIC", R"(<mimic joint="elbow" multiplier="0.01"/>)");
  dir.write("robot.urdf", urdf);
  expect_file_error((dir.path / "palm.json").string(),
                    {"palm.json", "wrist_link", "joint 'slide'", "mimics joint 'elbow'", "above link 'palm'", "robot.urdf"});
}

TEST(HandUrdf, PackageUrisResolveThroughTheSearchPath) {
  TempDir dir;
  dir.write("small.urdf", small_urdf());
  const std::string spec = dir.write("small.json", kSmallSpec);
  // Without a search path the package cannot be found: the error names the URDF and the URI.
  expect_file_error(spec, {"small.urdf", "link 'd'", "package://barrett/meshes/bh_finger_prox.stl", "no package"});
  // Through the spec's "package_paths", relative to the spec file.
  std::string text = kSmallSpec;
  const std::string rel = fs::relative(kModels, dir.path).string();
  replace_in(text, "\"urdf\": \"small.urdf\",", "\"urdf\": \"small.urdf\", \"package_paths\": [\"" + rel + "\"],");
  const std::string spec2 = dir.write("small2.json", text);
  const Hand h = Hand::load(spec2);
  EXPECT_NEAR(h.links()[h.link_index("d")].mesh.bounds.max().z(), kProx, 1e-9);
  // A directory that is itself the package also works.
  HandLoadOptions opt;
  opt.package_paths = {kModels + "/barrett"};
  EXPECT_NO_THROW(Hand::load(spec, opt));
  // The package exists but the file does not: a missing mesh, named with its link.
  dir.write("small.urdf", small_urdf("package://barrett/meshes/no_such_mesh.stl"));
  expect_file_error(spec, {"no_such_mesh.stl", "link 'd'", "not found"}, opt);
}

TEST(HandUrdf, MissingAndMalformedFilesNameTheFile) {
  TempDir dir;
  const std::string spec = dir.write("small.json", kSmallSpec);
  expect_file_error(spec, {"small.json", "urdf: no such file", "small.urdf"});
  dir.write("small.urdf", "<robot name=\"x\"><link name=\"a\"/><joint name=\"j\" type=\"revolute\"></robot>");
  expect_file_error(spec, {"small.urdf", "malformed URDF"});
  dir.write("small.urdf", "this is not XML");
  expect_file_error(spec, {"small.urdf", "malformed URDF"});
  dir.write("small.urdf", small_urdf("meshes/missing.stl"));
  expect_file_error(spec, {"meshes/missing.stl", "link 'd'", "not found"});
  dir.write("small.urdf", small_urdf("broken.stl"));
  dir.write("broken.stl", "solid broken\n  facet normal 0 0 1\n");
  expect_file_error(spec, {"broken.stl", "link 'd'"});
  expect_file_error((dir.path / "nope.json").string(), {"nope.json", "not found"});
  dir.write("bad.json", "{\"urdf\": ");
  expect_file_error((dir.path / "bad.json").string(), {"bad.json", "invalid JSON"});
  std::string floating = small_urdf();
  replace_in(floating, "name=\"j4\" type=\"continuous\"", "name=\"j4\" type=\"floating\"");
  dir.write("small.urdf", floating);
  expect_file_error(spec, {"small.urdf", "joint 'j4'", "floating"}, HandLoadOptions{{kModels}});
}

TEST(HandSpec, EveryFieldErrorNamesTheFileAndTheField) {
  TempDir dir;
  struct Case {
    std::string from, to;
    std::vector<std::string> needles;
  };
  const std::vector<Case> cases = {
      {"\"wrist_link\": \"bh_palm\",", "", {"wrist_link: missing field"}},
      {"\"wrist_link\": \"bh_palm\"", "\"wrist_link\": \"bh_wrist\"", {"wrist_link: no link 'bh_wrist'"}},
      {"\"wrist_link\": \"bh_palm\"", "\"wrist_link\": \"bh_f1_prox\"", {"wrist_link:", "mimics joint 'bh_j12'", "above link 'bh_f1_prox'"}},
      {"\"approach\": [0.0, 0.0, 1.0]", "\"approach\": \"up\"", {"approach: expected an array of 3 numbers"}},
      {"\"approach\": [0.0, 0.0, 1.0]", "\"approach\": [0, 0, 0]", {"approach: must be a non-zero vector"}},
      {"\"approach\": [0.0, 0.0, 1.0]", "\"approach\": [0, \"a\", 0]", {"approach[1]: expected a number"}},
      {"{\"joint\": \"bh_j32\"}", "{\"joint\": \"x\"}", {"dofs[3].joints[0].joint: no joint 'x' in bh8_28x.urdf"}},
      {"{\"joint\": \"bh_j32\"}", "{\"joint\": \"bh_j31\"}", {"dofs[3].joints[0].joint:", "fixed"}},
      {"{\"joint\": \"bh_j32\"}", "{\"joint\": \"bh_j33\"}", {"dofs[3].joints[0].joint:", "mimic", "bh_j32"}},
      {"{\"joint\": \"bh_j32\"}", "{\"joint\": \"bh_j12\"}", {"dofs[3].joints[0].joint:", "already driven by dofs[1]"}},
      {"{\"joint\": \"bh_j32\"}", "{\"joint\": 7}", {"dofs[3].joints[0].joint: expected a string"}},
      {"{\"joint\": \"bh_j32\"}", "{\"joint\": \"bh_j32\", \"ratio\": 0}", {"dofs[3].joints[0].ratio: must be non-zero"}},
      {"{\"joint\": \"bh_j32\"}", "{\"jiont\": \"bh_j32\"}", {"dofs[3].joints[0].jiont: unknown field"}},
      {"\"joints\": [{\"joint\": \"bh_j32\"}]", "\"joints\": []", {"dofs[3].joints: must not be empty"}},
      {"\"name\": \"f3_flex\", \"joints\": [{\"joint\": \"bh_j32\"}], ", "", {"dofs[3].name: missing field"}},
      {"\"name\": \"f3_flex\"", "\"name\": \"f2_flex\"", {"dofs[3].name: duplicate DOF name"}},
      {"\"name\": \"f1_flex\", \"joints\": [{\"joint\": \"bh_j12\"}], \"lower\": 0.0, \"upper\": 2.44",
       "\"name\": \"f1_flex\", \"joints\": [{\"joint\": \"bh_j12\"}], \"lower\": 2.0, \"upper\": 1.0",
       {"dofs[1].lower: lower limit 2 is greater than upper limit 1"}},
      {"\"name\": \"f1_flex\", \"joints\": [{\"joint\": \"bh_j12\"}], \"lower\": 0.0, \"upper\": 2.44",
       "\"name\": \"f1_flex\", \"joints\": [{\"joint\": \"bh_j12\"}], \"lower\": 0.0, \"upper\": 3.0",
       {"dofs[1].upper:", "bh_j12", "URDF limits"}},
      {"\"lower\": 0.0, \"upper\": 2.44, \"step\": 0.25}\n  ]", "\"lower\": 0.0, \"upper\": 2.44, \"step\": 0}\n  ]",
       {"dofs[3].step: must be positive"}},
      {"\"lower\": 0.0, \"upper\": 2.44, \"step\": 0.25}\n  ]", "\"lower\": 0.0, \"upper\": 2.44, \"step\": -1}\n  ]",
       {"dofs[3].step: must be positive"}},
      {"\"lower\": 0.0, \"upper\": 2.44, \"step\": 0.25}\n  ]", "\"lower\": 0.0, \"upper\": \"x\", \"step\": 0.25}\n  ]",
       {"dofs[3].upper: expected a number"}},
      {",\n    {\"name\": \"f3_flex\", \"joints\": [{\"joint\": \"bh_j32\"}], \"lower\": 0.0, \"upper\": 2.44, \"step\": 0.25}",
       "", {"dofs: joint 'bh_j32'", "driven by no DOF"}},
      {"{\"link\": \"bh_f1_prox\"", "{\"link\": \"bh_f9_prox\"", {"active_surfaces[1].link: no link 'bh_f9_prox'"}},
      {"{\"link\": \"bh_palm\", \"normal_cone\": {\"axis\": [0.0, 0.0, 1.0], \"half_angle_deg\": 10.0}}",
       "{\"link\": \"bh_palm\", \"normal_cone\": {\"axis\": [0.0, 0.0, 1.0], \"half_angle_deg\": 10.0}, "
       "\"box\": {\"min\": [1, 1, 1], \"max\": [2, 2, 2]}}",
       {"active_surfaces[0]: selects no face of link 'bh_palm'"}},
      {"{\"link\": \"bh_palm\", \"normal_cone\": {\"axis\": [0.0, 0.0, 1.0], \"half_angle_deg\": 10.0}}",
       "{\"link\": \"bh_palm\", \"normal_cone\": {\"axis\": [0.0, 0.0, 1.0], \"half_angle_deg\": 0}}",
       {"active_surfaces[0].normal_cone.half_angle_deg: must be in (0, 180]"}},
      {"{\"link\": \"bh_palm\", \"normal_cone\": {\"axis\": [0.0, 0.0, 1.0], \"half_angle_deg\": 10.0}}",
       "{\"link\": \"bh_palm\"}", {"active_surfaces[0]: needs exactly one of"}},
      {"{\"link\": \"bh_palm\", \"normal_cone\": {\"axis\": [0.0, 0.0, 1.0], \"half_angle_deg\": 10.0}}",
       "{\"link\": \"bh_palm\", \"faces\": [0, 999]}", {"active_surfaces[0].faces[1]: face 999 out of range"}},
      {"{\"link\": \"bh_palm\", \"normal_cone\": {\"axis\": [0.0, 0.0, 1.0], \"half_angle_deg\": 10.0}}",
       "{\"link\": \"bh_palm\", \"faces\": [0.5]}", {"active_surfaces[0].faces[0]: expected an integer"}},
      {"{\"link\": \"bh_palm\", \"normal_cone\": {\"axis\": [0.0, 0.0, 1.0], \"half_angle_deg\": 10.0}}",
       "{\"link\": \"bh_palm\", \"normal_cone\": {\"axis\": [0.0, 0.0, 1.0]}}",
       {"active_surfaces[0].normal_cone.half_angle_deg: missing field"}},
      {"{\"link\": \"bh_palm\", \"normal_cone\": {\"axis\": [0.0, 0.0, 1.0], \"half_angle_deg\": 10.0}}",
       "{\"link\": \"bh_palm\", \"normal_cone\": {\"axis\": [0.0, 0.0, 1.0], \"half_angle_deg\": 10.0}, "
       "\"box\": {\"min\": [1, 1, 1], \"max\": [0, 0, 0]}}",
       {"active_surfaces[0].box: min must not exceed max"}},
      {"\"name\": \"barrett_bh8_28x\"", "\"name\": \"barrett_bh8_28x\", \"colour\": 3", {"colour: unknown field"}},
      {"\"name\": \"barrett_bh8_28x\"", "\"name\": \"\"", {"name: must not be empty"}},
  };
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const std::string text = barrett_spec([&](std::string& t) { replace_in(t, cases[i].from, cases[i].to); });
    const std::string spec = dir.write("case" + std::to_string(i) + ".json", text);
    std::vector<std::string> needles = cases[i].needles;
    needles.push_back("case" + std::to_string(i) + ".json");
    SCOPED_TRACE("case " + std::to_string(i));
    expect_file_error(spec, needles);
  }
  // A whole field of the wrong type.
  const std::string wrong_type = dir.write("wrong_type.json", barrett_spec([](std::string& t) {
    const auto a = t.find("\"dofs\": [");
    const auto b = t.find("\"active_surfaces\"");
    t.replace(a, b - a, "\"dofs\": {\"spread\": 1},\n  ");
  }));
  expect_file_error(wrong_type, {"wrong_type.json", "dofs: expected an array, got an object"});
  // The unedited text loads (the cases above fail for their own reason only).
  EXPECT_NO_THROW(Hand::load(dir.write("ok.json", barrett_spec())));
}
