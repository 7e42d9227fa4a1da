// Bundled targets (models/targets) and paint files: loading, sizes, volumes against the documented
// dimensions, the flask's unreachable neck top, regions, round trips and every paint error.
#include <pairgrasp/error.hpp>
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/paint.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

namespace pg = pairgrasp;
namespace fs = std::filesystem;

namespace {

const double kPi = 3.14159265358979323846;

std::string target(const std::string& name) { return std::string(PAIRGRASP_MODEL_DIR) + "/targets/" + name; }

// Triangle count stored in a binary STL's header (bytes 80..83), read without the mesh loader.
std::uint32_t stl_triangle_count(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  in.seekg(80);
  unsigned char b[4] = {0, 0, 0, 0};
  in.read(reinterpret_cast<char*>(b), 4);
  return b[0] | (b[1] << 8) | (b[2] << 16) | (static_cast<std::uint32_t>(b[3]) << 24);
}

Eigen::Vector3d centroid(const pg::Mesh& m, Eigen::Index f) {
  return (m.vertices.row(m.faces(f, 0)) + m.vertices.row(m.faces(f, 1)) + m.vertices.row(m.faces(f, 2))).transpose() /
         3.0;
}

double tri_area(const pg::Mesh& m, Eigen::Index f) {
  const Eigen::Vector3d a = m.vertices.row(m.faces(f, 0)), b = m.vertices.row(m.faces(f, 1)),
                        c = m.vertices.row(m.faces(f, 2));
  return 0.5 * (b - a).cross(c - a).norm();
}

// Volume factor of an N-gon inscribed in a circle: (N / 2pi) sin(2pi / N).
double polygon_factor(int n) { return n / (2 * kPi) * std::sin(2 * kPi / n); }

// A unit cube [0,1]^3, two triangles per side, outward winding, built by hand.
pg::Mesh unit_cube() {
  pg::Mesh m;
  m.vertices.resize(8, 3);
  for (int i = 0; i < 8; ++i) m.vertices.row(i) << (i & 1), (i >> 1) & 1, (i >> 2) & 1;
  m.faces.resize(12, 3);
  m.faces << 0, 2, 1, 1, 2, 3,  // z = 0
      4, 5, 6, 5, 7, 6,         // z = 1
      0, 1, 4, 1, 5, 4,         // y = 0
      2, 6, 3, 3, 6, 7,         // y = 1
      0, 4, 2, 2, 4, 6,         // x = 0
      1, 3, 5, 3, 7, 5;         // x = 1
  m.source = "unit_cube";
  m.closed = true;
  return m;
}

class TempDir {
 public:
  TempDir() {
    std::random_device rd;
    path_ = fs::temp_directory_path() / ("pairgrasp-paint-" + std::to_string(rd()) + std::to_string(rd()));
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string file(const std::string& name, const std::string& content) const {
    const std::string p = (path_ / name).string();
    std::ofstream(p, std::ios::binary) << content;
    return p;
  }
  std::string path(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

}  // namespace

// ---------------------------------------------------------------- the bundled targets

TEST(Targets, LoadClosedHandSizedOnTheFloorInIncreasingPolygonCount) {
  long previous = 0;
  for (const char* name : {"box.stl", "mug.stl", "flask.stl"}) {
    SCOPED_TRACE(name);
    const pg::Mesh m = pg::load_mesh(target(name));
    EXPECT_TRUE(m.closed);
    EXPECT_GT(m.volume, 0.0);
    // Clean files: the loader removes or turns nothing, so paint indices are the file's faces.
    EXPECT_EQ(m.faces.rows(), static_cast<Eigen::Index>(stl_triangle_count(target(name))));
    EXPECT_EQ(m.cleanup.degenerate_faces, 0);
    EXPECT_EQ(m.cleanup.duplicate_faces, 0);
    EXPECT_EQ(m.cleanup.flipped_faces, 0);
    const Eigen::Vector3d lo = m.vertices.colwise().minCoeff(), hi = m.vertices.colwise().maxCoeff();
    const double extent = (hi - lo).maxCoeff();
    EXPECT_GT(extent, 0.02);
    EXPECT_LT(extent, 0.5);
    EXPECT_NEAR(lo.z(), 0.0, 1e-7) << "stands on z = 0";
    // symmetry axis along z: the body is centred on x = y = 0 (the mug's handle sticks out along +x)
    EXPECT_NEAR(lo.y() + hi.y(), 0.0, 1e-6);
    EXPECT_GT(m.faces.rows(), previous) << "polygon count increases box < mug < flask";
    previous = m.faces.rows();
  }
}

TEST(Targets, BoxVolumeIsTheProductOfItsSides) {
  const pg::Mesh m = pg::load_mesh(target("box.stl"));
  EXPECT_NEAR(m.volume, 0.06 * 0.06 * 0.12, 1e-3 * 0.06 * 0.06 * 0.12);
  const Eigen::Vector3d ext = m.vertices.colwise().maxCoeff() - m.vertices.colwise().minCoeff();
  EXPECT_NEAR(ext.x(), 0.06, 1e-6);
  EXPECT_NEAR(ext.y(), 0.06, 1e-6);
  EXPECT_NEAR(ext.z(), 0.12, 1e-6);
}

// The flask's outer radius as a function of height, rebuilt from the dimensions documented in
// models/README.md: bottom edge (0.040, 0) rounded with radius 0.006, straight cone to the
// shoulder corner (0.014, 0.100) rounded concavely with radius 0.040, neck radius 0.014 up to the
// lip, an outward half-round bead of radius 0.003 centred at (0.014, 0.147), top at 0.150.
double flask_radius(double z) {
  const double rb = 0.040, rn = 0.014, zs = 0.100, fb = 0.006, fs = 0.040, b = 0.003, h = 0.150;
  const double len = std::hypot(rb - rn, zs);
  const double nr = zs / len, nz = (rb - rn) / len;  // unit normal of the cone line pointing outwards
  // base fillet: centre at height fb and distance fb inside the cone line
  const double cbz = fb, cbr = rb - fb * (1.0 + nz) / nr;
  const double zt1 = cbz + fb * nz;  // tangent point on the cone
  // shoulder fillet: centre at distance fs outside the neck and outside the cone line
  const double csr = rn + fs, csz = zs + fs * (1.0 - nr) / nz;
  const double zt2 = csz - fs * nz;
  if (z <= zt1) return cbr + std::sqrt(std::max(0.0, fb * fb - (z - cbz) * (z - cbz)));
  if (z <= zt2) return rb + (rn - rb) * z / zs;
  if (z <= csz) return csr - std::sqrt(std::max(0.0, fs * fs - (z - csz) * (z - csz)));
  if (z <= h - 2 * b) return rn;
  return rn + std::sqrt(std::max(0.0, b * b - (z - (h - b)) * (z - (h - b))));
}

TEST(Targets, FlaskVolumeMatchesItsRevolvedProfile) {
  const pg::Mesh m = pg::load_mesh(target("flask.stl"));
  const int n = 200000;
  const double h = 0.150, dz = h / n;
  double integral = 0.0;
  for (int i = 0; i < n; ++i) {
    const double r = flask_radius((i + 0.5) * dz);
    integral += kPi * r * r * dz;
  }
  const double mouth = kPi * 0.010 * 0.010 * 0.025;
  const double expected = polygon_factor(80) * (integral - mouth);
  EXPECT_NEAR(m.volume, expected, 0.005 * expected) << "expected " << expected;
  EXPECT_NEAR(m.vertices.col(2).maxCoeff(), h, 1e-6);
  // widest at the bottom: base radius less the fillet's cut, inscribed 80-gon vertices at full radius
  EXPECT_NEAR(m.vertices.col(0).maxCoeff(), flask_radius(0.006), 1e-5);
}

// The mug as an implicit solid from its documented dimensions.
bool inside_mug(double x, double y, double z) {
  const double r = std::hypot(x, y);
  const bool body = r <= 0.040 && z >= 0.0 && z <= 0.100;
  const double hx = x - 0.050, hz = z - 0.050;
  const bool handle = std::hypot(std::hypot(hx, hz) - 0.028, y) <= 0.006;
  const bool cavity = r < 0.0355 && z > 0.006;
  const bool rim = std::hypot(r - 0.03775, z - 0.100) <= 0.003;
  return ((body || handle) && !cavity) || rim;
}

TEST(Targets, MugVolumeMatchesAGridEstimateOfItsShape) {
  const pg::Mesh m = pg::load_mesh(target("mug.stl"));
  const double s = 0.0005;
  long count = 0;
  for (double x = -0.042 + s / 2; x < 0.086; x += s)
    for (double y = -0.042 + s / 2; y < 0.042; y += s)
      for (double z = s / 2; z < 0.105; z += s) count += inside_mug(x, y, z);
  const double expected = count * s * s * s;
  EXPECT_NEAR(m.volume, expected, 0.01 * expected) << "grid estimate " << expected;
  // hollow: far less than the solid body, more than the bare walls
  EXPECT_LT(m.volume, 0.5 * kPi * 0.04 * 0.04 * 0.1);
  // the handle sticks out to x = 0.05 + 0.028 + 0.006
  EXPECT_NEAR(m.vertices.col(0).maxCoeff(), 0.084, 1e-4);
  EXPECT_NEAR(m.vertices.col(2).maxCoeff(), 0.103, 1e-4);
}

// ---------------------------------------------------------------- the bundled paint files

TEST(TargetPaint, FlaskOccludesTheNeckTopAndOnlyThere) {
  const pg::Mesh m = pg::load_mesh(target("flask.stl"));
  const pg::Mask free = pg::load_paint(target("flask.paint.json"), m);
  ASSERT_EQ(free.size(), m.faces.rows());
  long mouth = 0, lip = 0;
  double occluded_area = 0.0;
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f) {
    const Eigen::Vector3d c = centroid(m, f);
    const double r = std::hypot(c.x(), c.y());
    if (c.z() < 0.12) EXPECT_TRUE(free[f]) << "face " << f << " at z = " << c.z() << " should be free";
    // at and above 0.140 everything is occluded; below it only the inside of the mouth (r < 0.010)
    if (c.z() >= 0.140) EXPECT_FALSE(free[f]) << "face " << f;
    if (c.z() < 0.140 && r > 0.0101) EXPECT_TRUE(free[f]) << "neck face " << f << " at z = " << c.z();
    if (free[f]) continue;
    occluded_area += tri_area(m, f);
    EXPECT_GE(c.z(), 0.12) << "occluded face " << f << " is below the neck top";
    EXPECT_LT(r, 0.0175) << "occluded face " << f << " is off the neck";
    if (r < 0.0101) ++mouth;
    if (c.z() >= 0.144) ++lip;
  }
  EXPECT_GT(mouth, 80 * 3);  // mouth wall rings and floor
  EXPECT_GT(lip, 80 * 8);
  // Area by hand from the documented dimensions: mouth wall 2pi(0.010)(0.025), mouth floor
  // pi(0.010)^2, top annulus pi(0.014^2 - 0.010^2), bead (outer half-round, Pappus)
  // 2pi(0.003)(pi 0.014 + 2 0.003), neck strip 0.140..0.144: 2pi(0.014)(0.004). The mesh's strip
  // ends on a ring edge, up to one ring (4.9 mm) lower.
  const double expected = 2 * kPi * 0.010 * 0.025 + kPi * 0.010 * 0.010 + kPi * (0.014 * 0.014 - 0.010 * 0.010) +
                          2 * kPi * 0.003 * (kPi * 0.014 + 2 * 0.003) + 2 * kPi * 0.014 * 0.004;
  EXPECT_GT(occluded_area, 0.99 * expected);
  EXPECT_LT(occluded_area, 1.05 * expected);
}

TEST(TargetPaint, MugAndBoxOccludeTheFaceTheyStandOn) {
  for (const char* name : {"box", "mug"}) {
    SCOPED_TRACE(name);
    const pg::Mesh m = pg::load_mesh(target(std::string(name) + ".stl"));
    const pg::Mask free = pg::load_paint(target(std::string(name) + ".paint.json"), m);
    double occluded_area = 0.0;
    for (Eigen::Index f = 0; f < m.faces.rows(); ++f) {
      const bool on_floor = m.vertices(m.faces(f, 0), 2) == 0.0 && m.vertices(m.faces(f, 1), 2) == 0.0 &&
                            m.vertices(m.faces(f, 2), 2) == 0.0;
      EXPECT_EQ(free[f], !on_floor) << "face " << f;
      if (!free[f]) occluded_area += tri_area(m, f);
    }
    // the base: a 0.06 m square, or the mug's 64-gon of radius 0.040
    const double base = std::string(name) == "box" ? 0.06 * 0.06 : 0.5 * 64 * 0.04 * 0.04 * std::sin(2 * kPi / 64);
    EXPECT_NEAR(occluded_area, base, 1e-3 * base);
  }
}

// ---------------------------------------------------------------- regions

TEST(PaintRegions, MarkFacesByCentroidInOrder) {
  const pg::Mesh cube = unit_cube();
  // Hand computation: triangle centroids have coordinates in {0, 1/3, 2/3, 1}. Per side, one
  // triangle has its centroid at 1/3 and one at 2/3 along each in-plane axis.
  const pg::Mask top =
      pg::apply_regions(cube, {pg::PaintRegion::halfspace({0, 0, 0.5}, {0, 0, -2.0}, false)});
  // occluded: the two z = 0 triangles and, on each of the 4 sides, the one with centroid z = 1/3
  EXPECT_EQ(top.count(), 12 - 6);
  for (Eigen::Index f = 0; f < 12; ++f) EXPECT_EQ(top[f], centroid(cube, f).z() > 0.5) << f;

  // a later region overrides an earlier one
  const pg::Mask both = pg::apply_regions(
      cube, {pg::PaintRegion::halfspace({0, 0, 0.5}, {0, 0, -1}, false),
             pg::PaintRegion::box({-1, -1, -1}, {2, 2, 0.0}, true)});
  EXPECT_TRUE(both[0] && both[1]);  // z = 0 side free again
  EXPECT_EQ(both.count(), 8);

  // a sphere of radius 0.5 about the centre of side x = 1 holds exactly that side's two centroids
  // (at distance sqrt(2)/6 = 0.24); every other centroid is at least sqrt(1/9+1/36+1/4) = 0.62 away
  pg::Mask start = pg::Mask::Constant(12, false);
  start[0] = true;
  const pg::Mask sph = pg::apply_regions(cube, {pg::PaintRegion::sphere({1, 0.5, 0.5}, 0.5, true)}, start);
  EXPECT_EQ(sph.count(), 3);
  EXPECT_TRUE(sph[0] && sph[10] && sph[11]);

  // a cylinder about the vertical through the centre, radius 0.3: the ends cut by projection
  const auto cyl_low = pg::PaintRegion::cylinder({0.5, 0.5, -1.0}, {0.5, 0.5, 0.5}, 0.3, false);
  const pg::Mask low = pg::apply_regions(cube, {cyl_low});
  EXPECT_EQ(low.count(), 10);
  EXPECT_FALSE(low[0] || low[1]);  // the bottom side's centroids (distance sqrt(2)/6 from the axis)
  const pg::Mask high = pg::apply_regions(cube, {pg::PaintRegion::cylinder({0.5, 0.5, 2.0}, {0.5, 0.5, 0.1}, 0.3, false)});
  EXPECT_EQ(high.count(), 10);
  EXPECT_FALSE(high[2] || high[3]);  // the top side's
  EXPECT_EQ(pg::apply_regions(cube, {pg::PaintRegion::cylinder({0.5, 0.5, -1.0}, {0.5, 0.5, 2.0}, 0.2, false)}).count(), 12);

  // boundary counts as inside: the plane z = 0 marks the bottom side's centroids
  const pg::Mask plane = pg::apply_regions(cube, {pg::PaintRegion::halfspace({0, 0, 0}, {0, 0, -1}, false)});
  EXPECT_EQ(plane.count(), 10);
}

TEST(PaintRegions, BadRegionsAndSizesAreRejected) {
  const pg::Mesh cube = unit_cube();
  const double nan = std::nan("");
  auto expect_invalid = [](auto fn, const std::string& needle) {
    try {
      fn();
      ADD_FAILURE() << "no error, expected one naming " << needle;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expect_invalid([] { pg::PaintRegion::sphere({0, 0, 0}, 0.0, true); }, "radius");
  expect_invalid([] { pg::PaintRegion::sphere({0, 0, 0}, -1.0, true); }, "radius");
  expect_invalid([&] { pg::PaintRegion::sphere({nan, 0, 0}, 1.0, true); }, "center");
  expect_invalid([] { pg::PaintRegion::halfspace({0, 0, 0}, {0, 0, 0}, true); }, "normal");
  expect_invalid([&] { pg::PaintRegion::halfspace({0, nan, 0}, {0, 0, 1}, true); }, "point");
  expect_invalid([] { pg::PaintRegion::box({0, 0, 1}, {1, 1, 0}, true); }, "min");
  expect_invalid([] { pg::PaintRegion::cylinder({0, 0, 1}, {0, 0, 1}, 0.1, true); }, "end: must differ from start");
  expect_invalid([] { pg::PaintRegion::cylinder({0, 0, 0}, {0, 0, 1}, 0.0, true); }, "radius");
  expect_invalid([&] { pg::PaintRegion::cylinder({0, 0, 0}, {0, 0, nan}, 1.0, true); }, "end");
  expect_invalid([&] { pg::apply_regions(cube, {}, pg::Mask::Constant(3, true)); }, "start: expected 12, got 3");
  pg::PaintRegion bad;  // fields set by hand bypass the factories: apply_regions checks them
  bad.shape = pg::PaintRegion::Shape::sphere;
  bad.radius = -2.0;
  expect_invalid([&] { pg::apply_regions(cube, {pg::PaintRegion::box({0, 0, 0}, {1, 1, 1}, true), bad}); },
                 "regions[1].radius");
}

// ---------------------------------------------------------------- save / load round trip

TEST(PaintFiles, SaveThenLoadGivesTheSameMask) {
  const pg::Mesh m = pg::load_mesh(target("mug.stl"));
  TempDir dir;
  std::mt19937 rng(7);
  for (double p_free : {0.9, 0.5, 0.1, 1.0}) {
    SCOPED_TRACE(p_free);
    std::bernoulli_distribution coin(p_free);
    pg::Mask mask(m.faces.rows());
    for (Eigen::Index f = 0; f < mask.size(); ++f) mask[f] = coin(rng);
    mask[5] = true;
    const std::string path = dir.path("round.paint.json");
    pg::save_paint(path, m, mask);
    const pg::Mask back = pg::load_paint(path, m);
    ASSERT_EQ(back.size(), mask.size());
    EXPECT_TRUE((back.array() == mask.array()).all());
    // the file lists the smaller side: its size grows with min(free, occluded), not F
    const auto bytes = fs::file_size(path);
    const long smaller = std::min<long>(mask.count(), mask.size() - mask.count());
    EXPECT_LT(bytes, 200u + 7u * static_cast<unsigned long>(smaller));
  }
}

TEST(PaintFiles, SaveRejectsBadMasksAndUnwritablePaths) {
  const pg::Mesh cube = unit_cube();
  TempDir dir;
  EXPECT_THROW(pg::save_paint(dir.path("a.json"), cube, pg::Mask::Constant(11, true)), std::invalid_argument);
  try {
    pg::save_paint(dir.path("b.json"), cube, pg::Mask::Constant(12, false));
    ADD_FAILURE() << "an all-occluded mask was saved";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no free face"), std::string::npos) << e.what();
  }
  const std::string nowhere = dir.path("missing-dir/c.json");
  try {
    pg::save_paint(nowhere, cube, pg::Mask::Constant(12, true));
    ADD_FAILURE() << "wrote into a missing directory";
  } catch (const pg::FileError& e) {
    EXPECT_EQ(e.path(), nowhere);
  }
}

// ---------------------------------------------------------------- paint file errors

namespace {
const char* kHead = R"("format": "pairgrasp-paint", "version": 1, "faces": 12)";

// Writes `body` and expects load_paint to throw FileError naming the file and `field`.
void expect_file_error(const TempDir& dir, const std::string& body, const std::string& field) {
  SCOPED_TRACE(body);
  const std::string path = dir.file("bad.paint.json", body);
  try {
    pg::load_paint(path, unit_cube());
    ADD_FAILURE() << "no error for " << body;
  } catch (const pg::FileError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.path(), path);
    EXPECT_EQ(what.rfind(path, 0), 0u) << what;  // starts with the path
    EXPECT_NE(what.find(": " + field), std::string::npos) << what << "\n  (expected the field " << field << ")";
  }
}
}  // namespace

TEST(PaintFiles, EachBadFieldGivesAFileErrorNamingIt) {
  TempDir dir;
  const std::string h = kHead;
  expect_file_error(dir, "", "file: not valid JSON");
  expect_file_error(dir, "{\"format\": ", "file: not valid JSON");
  expect_file_error(dir, "[1, 2]", "file: expected a JSON object");
  expect_file_error(dir, R"({"version": 1, "faces": 12})", "format: missing");
  expect_file_error(dir, R"({"format": "stl-paint", "version": 1, "faces": 12})", "format");
  expect_file_error(dir, R"({"format": "pairgrasp-paint", "faces": 12})", "version: missing");
  expect_file_error(dir, R"({"format": "pairgrasp-paint", "version": 2, "faces": 12})", "version: unsupported");
  expect_file_error(dir, R"({"format": "pairgrasp-paint", "version": 1})", "faces: missing");
  expect_file_error(dir, R"({"format": "pairgrasp-paint", "version": 1, "faces": 5120})", "faces: the paint is for a mesh of 5120 faces");
  expect_file_error(dir, R"({"format": "pairgrasp-paint", "version": 1, "faces": "12"})", "faces: expected an integer");
  expect_file_error(dir, "{" + h + R"(, "occluders": [1]})", "occluders: unknown key");
  expect_file_error(dir, "{" + h + R"(, "default": "maybe"})", "default");
  expect_file_error(dir, "{" + h + R"(, "occluded": [3, 12]})", "occluded[1]: face index 12 is out of range");
  expect_file_error(dir, "{" + h + R"(, "occluded": [-1]})", "occluded[0]: face index -1 is out of range");
  expect_file_error(dir, "{" + h + R"(, "free": [1.5]})", "free[0]: expected an integer");
  expect_file_error(dir, "{" + h + R"(, "free": 3})", "free: expected an array");
  expect_file_error(dir, "{" + h + R"(, "free": [2], "occluded": [4, 2]})", "occluded[1]: face 2 is listed as both");
  expect_file_error(dir, "{" + h + R"(, "mesh": 7})", "mesh: expected a string");
  expect_file_error(dir, "{" + h + R"(, "regions": {"shape": "box"}})", "regions: expected an array");
  expect_file_error(dir, "{" + h + R"(, "regions": [{"shape": "cone", "mark": "free"}]})", "regions[0].shape: unknown shape");
  expect_file_error(dir, "{" + h + R"(, "regions": [{"point": [0,0,0], "normal": [0,0,1], "mark": "free"}]})", "regions[0].shape: missing");
  expect_file_error(dir, "{" + h + R"(, "regions": [{"shape": "halfspace", "point": [0,0,0], "normal": [0,0,1]}]})", "regions[0].mark: missing");
  expect_file_error(dir, "{" + h + R"(, "regions": [{"shape": "halfspace", "point": [0,0,0], "normal": [0,0,1], "mark": "hidden"}]})", "regions[0].mark");
  expect_file_error(dir, "{" + h + R"(, "regions": [{"shape": "halfspace", "point": [0,0], "normal": [0,0,1], "mark": "free"}]})", "regions[0].point: expected 3 numbers");
  expect_file_error(dir, "{" + h + R"(, "regions": [{"shape": "halfspace", "point": [0,0,0], "normal": [0,0,0], "mark": "free"}]})", "regions[0].normal: must be non-zero");
  expect_file_error(dir, "{" + h + R"(, "regions": [{"shape": "halfspace", "point": [0,"a",0], "normal": [0,0,1], "mark": "free"}]})", "regions[0].point[1]: expected a number");
  expect_file_error(dir, "{" + h + R"(, "regions": [{"shape": "box", "min": [0,0,1], "max": [1,1,0], "mark": "free"}]})", "regions[0].min: must be <= max");
  expect_file_error(dir, "{" + h + R"(, "regions": [{"shape": "box", "min": [0,0,0], "max": [1,1,1], "radius": 2, "mark": "free"}]})", "regions[0].radius: unknown key");
  expect_file_error(dir, "{" + h + R"(, "regions": [{"shape": "sphere", "center": [0,0,0], "radius": 0, "mark": "free"}]})", "regions[0].radius: must be > 0");
  expect_file_error(dir, "{" + h + R"(, "regions": [{"shape": "box", "min": [0,0,0], "max": [1,1,1], "mark": "free"}, {"shape": "sphere", "center": [0,0,0], "radius": -0.5, "mark": "free"}]})", "regions[1].radius: must be > 0");
  expect_file_error(dir, "{" + h + R"(, "regions": [{"shape": "sphere", "center": [0,0,0], "mark": "free"}]})", "regions[0].radius: missing");
  expect_file_error(dir, "{" + h + R"(, "regions": [{"shape": "cylinder", "start": [0,0,1], "end": [0,0,1], "radius": 1, "mark": "free"}]})", "regions[0].end: must differ from start");
  expect_file_error(dir, "{" + h + R"(, "regions": [{"shape": "cylinder", "start": [0,0,0], "end": [0,0,1], "radius": -1, "mark": "free"}]})", "regions[0].radius: must be > 0");
  expect_file_error(dir, "{" + h + R"(, "regions": [{"shape": "cylinder", "start": [0,0,0], "radius": 1, "mark": "free"}]})", "regions[0].end: missing");
  // JSON has no NaN or infinity: a NaN literal or an overflowing number is invalid JSON
  expect_file_error(dir, "{" + h + R"(, "regions": [{"shape": "sphere", "center": [0,0,NaN], "radius": 1, "mark": "free"}]})", "file: not valid JSON");
  expect_file_error(dir, "{" + h + R"(, "regions": [{"shape": "sphere", "center": [0,0,0], "radius": 1e999, "mark": "free"}]})", "file: not valid JSON");
}

TEST(PaintFiles, MissingFileIsAFileError) {
  TempDir dir;
  const std::string path = dir.path("nope.paint.json");
  try {
    pg::load_paint(path, unit_cube());
    ADD_FAILURE();
  } catch (const pg::FileError& e) {
    EXPECT_EQ(e.path(), path);
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos) << e.what();
  }
}

TEST(PaintFiles, APaintWithNoFreeFaceIsRefused) {
  TempDir dir;
  const std::string h = kHead;
  for (const std::string body :
       {"{" + h + R"(, "default": "occluded"})",
        "{" + h + R"(, "occluded": [0,1,2,3,4,5,6,7,8,9,10,11]})",
        "{" + h + R"(, "free": [3], "regions": [{"shape": "sphere", "center": [0.5,0.5,0.5], "radius": 2, "mark": "occluded"}]})"}) {
    SCOPED_TRACE(body);
    const std::string path = dir.file("none.paint.json", body);
    try {
      pg::load_paint(path, unit_cube());
      ADD_FAILURE() << "accepted a paint with no free face";
    } catch (const pg::FileError& e) {
      ADD_FAILURE() << "wrong error type: " << e.what();
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("paint leaves no free face"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
}

TEST(PaintFiles, ListsThenRegionsInOrder) {
  TempDir dir;
  const std::string h = kHead;
  // default occluded; face 0 and 1 listed free; then the z >= 0.5 half free; then a box at the top
  // corner (1,1,1) marks the top side's centroids near it occluded again.
  const std::string path = dir.file("ok.paint.json", "{" + h + R"(, "default": "occluded", "free": [0, 1],
    "comment": "test", "mesh": "unit_cube",
    "regions": [{"shape": "halfspace", "point": [0,0,0.5], "normal": [0,0,1], "mark": "free", "comment": "upper"},
                {"shape": "box", "min": [0.5,0.5,0.9], "max": [1,1,1], "mark": "occluded"}]})");
  const pg::Mesh cube = unit_cube();
  const pg::Mask m = pg::load_paint(path, cube);
  for (Eigen::Index f = 0; f < 12; ++f) {
    const Eigen::Vector3d c = centroid(cube, f);
    const bool top_corner = c.x() >= 0.5 && c.y() >= 0.5 && c.z() >= 0.9;
    const bool expected = !top_corner && (f <= 1 || c.z() >= 0.5);
    EXPECT_EQ(m[f], expected) << "face " << f;
  }
}
