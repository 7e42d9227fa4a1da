// Mesh loading, validation, clean-up, orientation and measures, checked against hand-computed
// facts (box volumes and areas, sphere bounds, explicit vertex transforms).
#include <pairgrasp/error.hpp>
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/planner.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using pairgrasp::FileError;
using pairgrasp::load_mesh;
using pairgrasp::make_mesh;
using pairgrasp::Mesh;
using pairgrasp::MeshLoadOptions;
using pairgrasp::Points;
using pairgrasp::Triangles;

namespace {

constexpr double kPi = 3.14159265358979323846;

// ------------------------------------------------------------------------------ test geometry

struct TriMesh {
  Points v;
  Triangles f;
};

// Axis-aligned box [lo, lo + size], 8 corners (index = x + 2y + 4z bits), 12 outward triangles.
TriMesh make_box(const Eigen::Vector3d& size, const Eigen::Vector3d& lo = Eigen::Vector3d::Zero()) {
  TriMesh m;
  m.v.resize(8, 3);
  for (int i = 0; i < 8; ++i)
    m.v.row(i) << lo.x() + ((i & 1) ? size.x() : 0.0), lo.y() + ((i & 2) ? size.y() : 0.0),
        lo.z() + ((i & 4) ? size.z() : 0.0);
  m.f.resize(12, 3);
  int n = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      // Corners on this side in cyclic order around the face.
      const int u = (axis + 1) % 3, w = (axis + 2) % 3;
      auto idx = [&](int bu, int bw) { return (side << axis) | (bu << u) | (bw << w); };
      std::array<int, 4> q{idx(0, 0), idx(1, 0), idx(1, 1), idx(0, 1)};
      // Outward normal is +axis for side 1, -axis for side 0: fix the cycle's sense accordingly.
      const Eigen::Vector3d a = m.v.row(q[0]), b = m.v.row(q[1]), c = m.v.row(q[2]);
      const double along = (b - a).cross(c - a)[axis];
      if ((along > 0) != (side == 1)) std::swap(q[1], q[3]);
      m.f.row(n++) << q[0], q[1], q[2];
      m.f.row(n++) << q[0], q[2], q[3];
    }
  return m;
}

// Icosahedron subdivided `levels` times and projected onto the sphere (centre, radius).
TriMesh make_icosphere(int levels, double radius, const Eigen::Vector3d& centre) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                                    {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& p : v) p.normalize();
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      return mid[key] = static_cast<int>(v.size()) - 1;
    };
    std::vector<std::array<int, 3>> g;
    for (const auto& t3 : f) {
      const int a = midpoint(t3[0], t3[1]), b = midpoint(t3[1], t3[2]), c = midpoint(t3[2], t3[0]);
      g.push_back({t3[0], a, c});
      g.push_back({t3[1], b, a});
      g.push_back({t3[2], c, b});
      g.push_back({a, b, c});
    }
    f = g;
  }
  TriMesh m;
  m.v.resize(static_cast<Eigen::Index>(v.size()), 3);
  for (std::size_t i = 0; i < v.size(); ++i) m.v.row(i) = (centre + radius * v[i]).transpose();
  m.f.resize(static_cast<Eigen::Index>(f.size()), 3);
  for (std::size_t i = 0; i < f.size(); ++i) m.f.row(i) << f[i][0], f[i][1], f[i][2];
  return m;
}

// ------------------------------------------------------------------------------ file writers

void write_binary_stl(const fs::path& path, const TriMesh& m, const std::string& header = "pairgrasp test") {
  std::ofstream out(path, std::ios::binary);
  char head[80] = {};
  std::memcpy(head, header.data(), std::min<std::size_t>(header.size(), 80));
  out.write(head, 80);
  const std::uint32_t n = static_cast<std::uint32_t>(m.f.rows());
  out.write(reinterpret_cast<const char*>(&n), 4);
  for (Eigen::Index i = 0; i < m.f.rows(); ++i) {
    const Eigen::Vector3d a = m.v.row(m.f(i, 0)), b = m.v.row(m.f(i, 1)), c = m.v.row(m.f(i, 2));
    const Eigen::Vector3d nn = (b - a).cross(c - a).normalized();
    float rec[12] = {float(nn.x()), float(nn.y()), float(nn.z())};
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) rec[3 + 3 * k + d] = static_cast<float>(m.v(m.f(i, k), d));
    out.write(reinterpret_cast<const char*>(rec), sizeof rec);
    const std::uint16_t attr = 0;
    out.write(reinterpret_cast<const char*>(&attr), 2);
  }
}

std::string num(double x) {
  std::ostringstream s;
  s.precision(17);
  s << x;
  return s.str();
}

void write_ascii_stl(const fs::path& path, const TriMesh& m) {
  std::ofstream out(path);
  out << "solid test\n";
  for (Eigen::Index i = 0; i < m.f.rows(); ++i) {
    out << "  facet normal 0 0 0\n    outer loop\n";
    for (int k = 0; k < 3; ++k)
      out << "      vertex " << num(m.v(m.f(i, k), 0)) << " " << num(m.v(m.f(i, k), 1)) << " "
          << num(m.v(m.f(i, k), 2)) << "\n";
    out << "    endloop\n  endfacet\n";
  }
  out << "endsolid test\n";
}

// A box as quads (OBJ "f a b c d", 1-based), so the loader's triangulation is exercised.
void write_obj_box_quads(const fs::path& path, const TriMesh& box) {
  std::ofstream out(path);
  out << "# box\no box\n";
  for (Eigen::Index i = 0; i < box.v.rows(); ++i)
    out << "v " << num(box.v(i, 0)) << " " << num(box.v(i, 1)) << " " << num(box.v(i, 2)) << "\n";
  for (Eigen::Index i = 0; i < box.f.rows(); i += 2)  // faces 2k, 2k+1 are (q0 q1 q2), (q0 q2 q3)
    out << "f " << box.f(i, 0) + 1 << " " << box.f(i, 1) + 1 << " " << box.f(i, 2) + 1 << " "
        << box.f(i + 1, 2) + 1 << "\n";
}

void write_ply_ascii(const fs::path& path, const TriMesh& m) {
  std::ofstream out(path);
  out << "ply\nformat ascii 1.0\nelement vertex " << m.v.rows()
      << "\nproperty float x\nproperty float y\nproperty float z\nelement face " << m.f.rows()
      << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (Eigen::Index i = 0; i < m.v.rows(); ++i)
    out << num(m.v(i, 0)) << " " << num(m.v(i, 1)) << " " << num(m.v(i, 2)) << "\n";
  for (Eigen::Index i = 0; i < m.f.rows(); ++i) out << "3 " << m.f(i, 0) << " " << m.f(i, 1) << " " << m.f(i, 2) << "\n";
}

// COLLADA with one geometry instanced by one node per matrix (row-major 4x4 as in <matrix>).
void write_dae(const fs::path& path, const TriMesh& m, const std::string& up_axis, const std::string& unit_attr,
               const std::vector<Eigen::Matrix4d>& nodes = {Eigen::Matrix4d::Identity()}) {
  std::ofstream out(path);
  out << "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n"
         "<COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" version=\"1.4.1\">\n"
         "  <asset>\n    <contributor><authoring_tool>test</authoring_tool></contributor>\n";
  if (!unit_attr.empty()) out << "    <unit " << unit_attr << "/>\n";
  out << "    <up_axis>" << up_axis << "</up_axis>\n  </asset>\n"
      << "  <library_geometries>\n    <geometry id=\"g\" name=\"g\">\n      <mesh>\n"
      << "        <source id=\"g-pos\">\n          <float_array id=\"g-pos-arr\" count=\"" << 3 * m.v.rows() << "\">";
  for (Eigen::Index i = 0; i < m.v.rows(); ++i) out << num(m.v(i, 0)) << " " << num(m.v(i, 1)) << " " << num(m.v(i, 2)) << " ";
  out << "</float_array>\n          <technique_common>\n            <accessor source=\"#g-pos-arr\" count=\""
      << m.v.rows() << "\" stride=\"3\">\n"
      << "              <param name=\"X\" type=\"float\"/><param name=\"Y\" type=\"float\"/><param name=\"Z\" type=\"float\"/>\n"
      << "            </accessor>\n          </technique_common>\n        </source>\n"
      << "        <vertices id=\"g-vtx\"><input semantic=\"POSITION\" source=\"#g-pos\"/></vertices>\n"
      << "        <triangles count=\"" << m.f.rows() << "\">\n          <input semantic=\"VERTEX\" source=\"#g-vtx\" offset=\"0\"/>\n          <p>";
  for (Eigen::Index i = 0; i < m.f.rows(); ++i) out << m.f(i, 0) << " " << m.f(i, 1) << " " << m.f(i, 2) << " ";
  out << "</p>\n        </triangles>\n      </mesh>\n    </geometry>\n  </library_geometries>\n"
      << "  <library_visual_scenes>\n    <visual_scene id=\"scene\" name=\"scene\">\n";
  for (std::size_t n = 0; n < nodes.size(); ++n) {
    out << "      <node id=\"n" << n << "\" name=\"n" << n << "\">\n        <matrix>";
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) out << num(nodes[n](r, c)) << " ";
    out << "</matrix>\n        <instance_geometry url=\"#g\"/>\n      </node>\n";
  }
  out << "    </visual_scene>\n  </library_visual_scenes>\n"
      << "  <scene><instance_visual_scene url=\"#scene\"/></scene>\n</COLLADA>\n";
}

// An L-shaped prism (cross-section (0,0) (2,0) (2,1) (1,1) (1,3) (0,3), times `s`, height h),
// its two caps as concave hexagons starting at the corner next to the reflex one, so that a fan
// from the first corner would leave the polygon. Area of the L: 4 s^2, perimeter 10 s.
struct PolyMesh {
  Points v;
  std::vector<std::vector<int>> polys;
};

PolyMesh make_l_prism(double s, double h) {
  const double xy[6][2] = {{2, 1}, {1, 1}, {1, 3}, {0, 3}, {0, 0}, {2, 0}};  // counter-clockwise
  PolyMesh m;
  m.v.resize(12, 3);
  for (int i = 0; i < 6; ++i) {
    m.v.row(i) << s * xy[i][0], s * xy[i][1], 0.0;
    m.v.row(6 + i) << s * xy[i][0], s * xy[i][1], h;
  }
  m.polys.push_back({5, 4, 3, 2, 1, 0});    // bottom, seen from below
  m.polys.push_back({6, 7, 8, 9, 10, 11});  // top
  for (int i = 0; i < 6; ++i) m.polys.push_back({i, (i + 1) % 6, 6 + (i + 1) % 6, 6 + i});
  return m;
}

// PLY with polygons, extra vertex and face properties and an extra element, in any format.
void write_ply_polys(const fs::path& path, const PolyMesh& m, const std::string& format) {
  std::ofstream out(path, std::ios::binary);
  out << "ply\nformat " << format << " 1.0\ncomment written by a test\nelement vertex " << m.v.rows()
      << "\nproperty double x\nproperty float y\nproperty double z\nproperty uchar red\nelement face "
      << m.polys.size() << "\nproperty uchar flags\nproperty list uchar int vertex_indices\n"
      << "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n";
  const bool ascii = format == "ascii";
  const bool big = format == "binary_big_endian";
  auto put = [&](const auto value) {
    if (ascii) {
      out << num(static_cast<double>(value)) << " ";
      return;
    }
    char b[sizeof value];
    std::memcpy(b, &value, sizeof value);
    if (big) std::reverse(b, b + sizeof value);
    out.write(b, sizeof value);
  };
  for (Eigen::Index i = 0; i < m.v.rows(); ++i) {
    put(m.v(i, 0));
    put(static_cast<float>(m.v(i, 1)));
    put(m.v(i, 2));
    put(static_cast<std::uint8_t>(200));
    if (ascii) out << "\n";
  }
  for (const auto& p : m.polys) {
    put(static_cast<std::uint8_t>(1));
    put(static_cast<std::uint8_t>(p.size()));
    for (int i : p) put(static_cast<std::int32_t>(i));
    if (ascii) out << "\n";
  }
  put(std::int32_t{0});
  put(std::int32_t{1});
  if (ascii) out << "\n";
}

void write_obj_polys(const fs::path& path, const PolyMesh& m) {
  std::ofstream out(path);
  for (Eigen::Index i = 0; i < m.v.rows(); ++i)
    out << "v " << num(m.v(i, 0)) << " " << num(m.v(i, 1)) << " " << num(m.v(i, 2)) << "\n";
  for (const auto& p : m.polys) {
    out << "f";
    for (int i : p) out << " " << i + 1;
    out << "\n";
  }
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

// Rows sorted lexicographically, for comparing vertex sets.
std::vector<Eigen::Vector3d> sorted_rows(const Points& p) {
  std::vector<Eigen::Vector3d> r;
  for (Eigen::Index i = 0; i < p.rows(); ++i) r.push_back(p.row(i).transpose());
  std::sort(r.begin(), r.end(), [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
  });
  return r;
}

double max_set_distance(const Points& a, const Points& b) {
  // Largest distance from a point of one set to the nearest of the other (brute force).
  double worst = 0.0;
  auto one_way = [&](const Points& x, const Points& y) {
    for (Eigen::Index i = 0; i < x.rows(); ++i) {
      double best = INFINITY;
      for (Eigen::Index j = 0; j < y.rows(); ++j) best = std::min(best, (x.row(i) - y.row(j)).norm());
      worst = std::max(worst, best);
    }
  };
  one_way(a, b);
  one_way(b, a);
  return worst;
}

// Faces as sets of corner positions (orientation kept by rotating the smallest corner first).
std::vector<std::array<double, 9>> face_keys(const Mesh& m, int digits = 6) {
  const double q = std::pow(10.0, digits);
  std::vector<std::array<double, 9>> keys;
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f) {
    std::array<std::array<double, 3>, 3> c;
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) c[k][d] = std::round(m.vertices(m.faces(f, k), d) * q) / q;
    const int first = static_cast<int>(std::min_element(c.begin(), c.end()) - c.begin());
    std::array<double, 9> key;
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) key[3 * k + d] = c[(first + k) % 3][d];
    keys.push_back(key);
  }
  std::sort(keys.begin(), keys.end());
  return keys;
}

class MeshFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device rd;
    dir_ = fs::temp_directory_path() / ("pairgrasp_test_mesh_" + std::to_string(rd()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string file(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

// Expects FileError whose message contains the path (and `fragment` when given).
template <class F>
void expect_file_error(F&& load, const std::string& path, const std::string& fragment = "") {
  try {
    load();
    ADD_FAILURE() << "no FileError for " << path;
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_EQ(e.path(), path);
    if (!fragment.empty()) EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

template <class F>
void expect_invalid_argument(F&& call, const std::string& fragment) {
  try {
    call();
    ADD_FAILURE() << "no std::invalid_argument (expected one mentioning '" << fragment << "')";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

void expect_box(const Mesh& m, const Eigen::Vector3d& size, const Eigen::Vector3d& lo, double rel = 1e-6) {
  const double scale = size.maxCoeff();
  EXPECT_EQ(m.vertices.rows(), 8);
  EXPECT_EQ(m.faces.rows(), 12);
  EXPECT_TRUE(m.closed);
  EXPECT_EQ(m.boundary_edges, 0);
  EXPECT_EQ(m.non_manifold_edges, 0);
  const double volume = size.prod();
  const double area = 2.0 * (size.x() * size.y() + size.y() * size.z() + size.z() * size.x());
  EXPECT_NEAR(m.volume, volume, rel * volume);
  EXPECT_NEAR(m.area, area, rel * area);
  EXPECT_LT((m.center_of_mass - (lo + size / 2)).norm(), rel * scale);
  EXPECT_LT((m.bounds.min() - lo).norm(), rel * scale);
  EXPECT_LT((m.bounds.max() - (lo + size)).norm(), rel * scale);
  // Outward: each face normal points away from the box centre.
  const Eigen::Vector3d centre = lo + size / 2;
  for (int f = 0; f < m.faces.rows(); ++f) {
    const Eigen::Vector3d a = m.vertices.row(m.faces(f, 0));
    EXPECT_GT(m.face_normal(f).dot(a - centre), 0.0) << "face " << f;
  }
}

}  // namespace

// ------------------------------------------------------------------------------ loading formats

TEST_F(MeshFiles, BinaryStlCubeWeldsToEightVertices) {
  const double side = 0.1;
  const Eigen::Vector3d lo(0.3, -0.2, 0.05);
  const TriMesh box = make_box(Eigen::Vector3d::Constant(side), lo);
  write_binary_stl(file("cube.stl"), box);
  const Mesh m = load_mesh(file("cube.stl"));
  expect_box(m, Eigen::Vector3d::Constant(side), lo);
  EXPECT_NEAR(m.volume, side * side * side, 1e-6 * side * side * side);
  EXPECT_NEAR(m.area, 6 * side * side, 1e-6 * side * side);
  EXPECT_EQ(m.cleanup.welded_vertices, 36 - 8);
  EXPECT_EQ(m.cleanup.unused_vertices, 0);
  EXPECT_EQ(m.cleanup.flipped_faces, 0);
  EXPECT_EQ(m.cleanup.degenerate_faces, 0);
  EXPECT_EQ(m.cleanup.duplicate_faces, 0);
  EXPECT_EQ(m.source, file("cube.stl"));
}

TEST_F(MeshFiles, BinaryStlWhoseHeaderStartsWithSolid) {
  // Many exporters write "solid ..." into the binary header; it must not be read as ASCII.
  const TriMesh box = make_box(Eigen::Vector3d(0.02, 0.03, 0.04));
  write_binary_stl(file("solid_header.stl"), box, "solid exported-by-a-cad-tool");
  expect_box(load_mesh(file("solid_header.stl")), Eigen::Vector3d(0.02, 0.03, 0.04), Eigen::Vector3d::Zero());
}

TEST_F(MeshFiles, BinaryStlWhoseHeaderStartsWithPlyIsStillStl) {
  // Files that start like PLY go to pairgrasp's PLY reader, but a binary STL's header is free text.
  const TriMesh box = make_box(Eigen::Vector3d(0.02, 0.03, 0.04));
  write_binary_stl(file("ply_header.stl"), box, "ply-exporter 2.1");
  expect_box(load_mesh(file("ply_header.stl")), Eigen::Vector3d(0.02, 0.03, 0.04), Eigen::Vector3d::Zero());
}

TEST_F(MeshFiles, AsciiStlCubeWeldsToEightVertices) {
  const double side = 2.5;
  const Eigen::Vector3d lo(-1.0, 4.0, 0.5);
  write_ascii_stl(file("cube_ascii.stl"), make_box(Eigen::Vector3d::Constant(side), lo));
  const Mesh m = load_mesh(file("cube_ascii.stl"));
  expect_box(m, Eigen::Vector3d::Constant(side), lo);
  EXPECT_NEAR(m.volume, side * side * side, 1e-6 * side * side * side);
  EXPECT_NEAR(m.area, 6 * side * side, 1e-6 * side * side);
  EXPECT_EQ(m.cleanup.welded_vertices, 28);
}

TEST_F(MeshFiles, ObjWithQuadsLoads) {
  const Eigen::Vector3d size(0.04, 0.05, 0.06), lo(0.01, 0.02, -0.03);
  write_obj_box_quads(file("box.obj"), make_box(size, lo));
  const Mesh m = load_mesh(file("box.obj"));
  expect_box(m, size, lo);
  EXPECT_EQ(m.cleanup.flipped_faces, 0);
}

TEST_F(MeshFiles, PlyLoads) {
  const Eigen::Vector3d size(0.07, 0.02, 0.03), lo(-0.01, 0.0, 0.2);
  write_ply_ascii(file("box.ply"), make_box(size, lo));
  const Mesh m = load_mesh(file("box.ply"));
  expect_box(m, size, lo);
  EXPECT_EQ(m.cleanup.welded_vertices, 0);
}

TEST_F(MeshFiles, ScaleLoadsMillimetresAsMetres) {
  const Eigen::Vector3d size_mm(100, 200, 300), lo_mm(10, -20, 30);
  write_binary_stl(file("box_mm.stl"), make_box(size_mm, lo_mm));
  MeshLoadOptions mm;
  mm.scale = 0.001;
  const Mesh m = load_mesh(file("box_mm.stl"), mm);
  expect_box(m, size_mm * 0.001, lo_mm * 0.001);
  EXPECT_NEAR(m.volume, 0.006, 1e-9);
}

TEST_F(MeshFiles, ColladaZUpMetresMatchesStl) {
  // An asymmetric box off the origin: any axis rotation would show in the vertex set.
  const Eigen::Vector3d size(0.1, 0.2, 0.3), lo(0.05, -0.4, 0.7);
  const TriMesh box = make_box(size, lo);
  write_binary_stl(file("box.stl"), box);
  write_dae(file("box.dae"), box, "Z_UP", "name=\"meter\" meter=\"1\"");
  const Mesh from_stl = load_mesh(file("box.stl"));
  const Mesh from_dae = load_mesh(file("box.dae"));
  const auto a = sorted_rows(from_stl.vertices), b = sorted_rows(from_dae.vertices);
  ASSERT_EQ(a.size(), 8u);
  ASSERT_EQ(b.size(), 8u);
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_LT((a[i] - b[i]).norm(), 1e-6) << i;
  EXPECT_EQ(face_keys(from_stl), face_keys(from_dae));
  expect_box(from_dae, size, lo);
}

TEST_F(MeshFiles, ColladaCentimetresZUpIsScaledAndNotRotated) {
  const Eigen::Vector3d size(10, 20, 30), lo(0, 0, 0);  // centimetres in the file
  Eigen::Matrix4d node = Eigen::Matrix4d::Identity();
  node.topRightCorner<3, 1>() << 1, 2, 3;  // node translation, file units
  write_dae(file("box_cm.dae"), make_box(size, lo), "Z_UP", "name=\"centimeter\" meter=\"0.01\"", {node});
  const Mesh m = load_mesh(file("box_cm.dae"));
  // Metres, authored axes: [0.01, 0.02, 0.03] + [0, 0.1] x [0, 0.2] x [0, 0.3].
  expect_box(m, size * 0.01, Eigen::Vector3d(0.01, 0.02, 0.03));
  EXPECT_NEAR(m.volume, 0.1 * 0.2 * 0.3, 1e-9);

  // With the caller's scale on top of the unit.
  MeshLoadOptions half;
  half.scale = 0.5;
  expect_box(load_mesh(file("box_cm.dae"), half), size * 0.005, Eigen::Vector3d(0.005, 0.01, 0.015));
}

TEST_F(MeshFiles, ColladaYUpAndMissingUnitKeepAuthoredCoordinates) {
  const Eigen::Vector3d size(0.1, 0.2, 0.3), lo(0.0, 0.1, 0.0);
  write_dae(file("y_up.dae"), make_box(size, lo), "Y_UP", "");
  expect_box(load_mesh(file("y_up.dae")), size, lo);
  write_dae(file("x_up.dae"), make_box(size, lo), "X_UP", "name=\"inch\" meter=\"0.0254\"");
  expect_box(load_mesh(file("x_up.dae")), size * 0.0254, lo * 0.0254);
}

TEST_F(MeshFiles, ColladaNodeTransformsAreAppliedAndInstancesMerged) {
  const TriMesh box = make_box(Eigen::Vector3d(1, 2, 3));
  // Node 0: 90 degrees about z then a shift; node 1: a mirror in x (determinant -1) and a shift.
  Eigen::Matrix4d n0 = Eigen::Matrix4d::Identity(), n1 = Eigen::Matrix4d::Identity();
  n0.topLeftCorner<3, 3>() << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  n0.topRightCorner<3, 1>() << 10, 0, 0;
  n1(0, 0) = -1;
  n1.topRightCorner<3, 1>() << -10, 0, 0;
  write_dae(file("two.dae"), box, "Z_UP", "meter=\"0.1\"", {n0, n1});
  const Mesh m = load_mesh(file("two.dae"));
  Points expected(16, 3);
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector4d p(box.v(i, 0), box.v(i, 1), box.v(i, 2), 1.0);
    expected.row(i) = 0.1 * (n0 * p).head<3>().transpose();
    expected.row(8 + i) = 0.1 * (n1 * p).head<3>().transpose();
  }
  ASSERT_EQ(m.vertices.rows(), 16);
  ASSERT_EQ(m.faces.rows(), 24);
  EXPECT_LT(max_set_distance(m.vertices, expected), 1e-6);
  EXPECT_TRUE(m.closed);
  EXPECT_NEAR(m.volume, 2 * 0.1 * 0.2 * 0.3, 1e-8);
  // The mirrored instance was kept outward by the loader, not by re-orientation.
  EXPECT_EQ(m.cleanup.flipped_faces, 0);
  // Equal volumes: the centre of mass is the mean of the two transformed box centres.
  const Eigen::Vector4d c(0.5, 1.0, 1.5, 1.0);
  const Eigen::Vector3d com = 0.1 * 0.5 * ((n0 * c).head<3>() + (n1 * c).head<3>());
  EXPECT_LT((m.center_of_mass - com).norm(), 1e-8);
}

TEST_F(MeshFiles, ConcavePolygonsFromPlyAndObjAreTriangulatedInside) {
  // Independent facts: area 2 * 4 s^2 + 10 s * h, volume 4 s^2 h, centroid of the L at
  // (0.75 s, 1.25 s). A triangulation leaving the polygon would overlap and add area, or turn
  // a cap triangle over.
  const double s = 0.01, h = 0.005;
  const PolyMesh prism = make_l_prism(s, h);
  std::vector<std::string> files;
  for (const std::string format : {"ascii", "binary_little_endian", "binary_big_endian"}) {
    files.push_back(file("l_" + format + ".ply"));
    write_ply_polys(files.back(), prism, format);
  }
  files.push_back(file("l.obj"));
  write_obj_polys(files.back(), prism);
  for (const std::string& path : files) {
    SCOPED_TRACE(path);
    const Mesh m = load_mesh(path);
    EXPECT_EQ(m.vertices.rows(), 12);
    EXPECT_EQ(m.faces.rows(), 2 * 4 + 6 * 2);  // a hexagon gives 4 triangles, a quad 2
    EXPECT_TRUE(m.closed);
    EXPECT_NEAR(m.area, 8 * s * s + 10 * s * h, 1e-6 * m.area);
    EXPECT_NEAR(m.volume, 4 * s * s * h, 1e-6 * m.volume);
    EXPECT_LT((m.center_of_mass - Eigen::Vector3d(0.75 * s, 1.25 * s, h / 2)).norm(), 1e-7 * s);
    EXPECT_EQ(m.cleanup.flipped_faces, 0);
    for (int f = 0; f < m.faces.rows(); ++f) {
      const Eigen::Vector3d n = m.face_normal(f);
      const double z = m.vertices.row(m.faces(f, 0)).z();
      if (std::abs(n.z()) > 0.5) EXPECT_NEAR(n.z(), z > h / 2 ? 1.0 : -1.0, 1e-9) << "face " << f;
    }
  }
}

// ------------------------------------------------------------------------------ orientation

TEST(MeshOrientation, SomeFlippedFacesAreTurnedBack) {
  const Eigen::Vector3d size(0.3, 0.2, 0.1);
  const TriMesh box = make_box(size);
  for (const std::vector<int>& flipped : {std::vector<int>{1, 4, 7}, std::vector<int>{0, 2, 3, 5, 6, 8, 11}}) {
    Triangles f = box.f;
    for (int i : flipped) std::swap(f(i, 1), f(i, 2));
    const Mesh m = make_mesh(box.v, f, "partly flipped");
    EXPECT_EQ(m.cleanup.flipped_faces, static_cast<int>(flipped.size()));
    EXPECT_TRUE(m.closed);
    EXPECT_NEAR(m.volume, size.prod(), 1e-12);
    EXPECT_EQ(m.faces, box.f);  // exactly the outward source faces, same order
  }
}

TEST(MeshOrientation, InsideOutCubeIsFlippedOutward) {
  const TriMesh box = make_box(Eigen::Vector3d::Constant(0.05), Eigen::Vector3d(1, 2, 3));
  Triangles f = box.f;
  f.col(1).swap(f.col(2));
  const Mesh m = make_mesh(box.v, f);
  EXPECT_EQ(m.cleanup.flipped_faces, 12);
  EXPECT_NEAR(m.volume, 0.05 * 0.05 * 0.05, 1e-12);
  EXPECT_EQ(m.faces, box.f);

  MeshLoadOptions keep;
  keep.orient = false;
  const Mesh raw = make_mesh(box.v, f, "raw", keep);
  EXPECT_EQ(raw.cleanup.flipped_faces, 0);
  EXPECT_TRUE(raw.closed);
  EXPECT_NEAR(raw.volume, -0.05 * 0.05 * 0.05, 1e-12);  // signed, as authored
}

TEST(MeshOrientation, FlatClosedSurfaceHasNoInside) {
  // A square covered twice, each side triangulated along a different diagonal: every edge is
  // shared by two faces traversing it in opposite directions, but the surface encloses nothing
  // (found by fuzzing the COLLADA reader: a closed mesh of volume 0).
  Points v(4, 3);
  v << 0, 0, 0, 0.1, 0, 0, 0.1, 0.1, 0, 0, 0.1, 0;
  Triangles f(4, 3);
  f << 0, 1, 2, 0, 2, 3, 1, 0, 3, 1, 3, 2;
  for (bool orient : {true, false}) {
    MeshLoadOptions o;
    o.orient = orient;
    const Mesh m = make_mesh(v, f, "pillow", o);
    EXPECT_EQ(m.boundary_edges, 0);
    EXPECT_EQ(m.non_manifold_edges, 0);
    EXPECT_FALSE(m.closed);
    EXPECT_EQ(m.volume, 0.0);
    EXPECT_NEAR(m.area, 0.02, 1e-15);
  }
}

TEST(MeshOrientation, CavityPointsInwardAndDisjointShellsOutward) {
  // Hollow box: outer 1 m cube, inner 0.5 m cube inside it. Whatever the source winding, the
  // inner wall ends up facing the cavity and the volume is 1 - 0.125.
  const TriMesh outer = make_box(Eigen::Vector3d::Constant(1.0));
  const TriMesh inner = make_box(Eigen::Vector3d::Constant(0.5), Eigen::Vector3d::Constant(0.25));
  Points v(16, 3);
  v << outer.v, inner.v;
  for (bool inner_reversed : {false, true}) {
    Triangles f(24, 3);
    Triangles fi = inner.f.array() + 8;
    if (inner_reversed) fi.col(1).swap(fi.col(2));
    f << outer.f, fi;
    const Mesh m = make_mesh(v, f, "hollow");
    EXPECT_TRUE(m.closed);
    EXPECT_NEAR(m.volume, 1.0 - 0.125, 1e-12);
    EXPECT_EQ(m.cleanup.flipped_faces, inner_reversed ? 0 : 12);
    EXPECT_NEAR(m.area, 6.0 + 6 * 0.25, 1e-12);
    // Inner wall normals point toward the centre (into the cavity).
    for (int face = 12; face < 24; ++face) {
      const Eigen::Vector3d a = m.vertices.row(m.faces(face, 0));
      EXPECT_LT(m.face_normal(face).dot(a - Eigen::Vector3d::Constant(0.5)), 0.0);
    }
  }
  // Two disjoint inside-out cubes and two overlapping ones: every shell made outward.
  for (double shift : {2.0, 0.5}) {
    const TriMesh b = make_box(Eigen::Vector3d::Constant(1.0), Eigen::Vector3d(shift, 0.2, 0.1));
    Points v2(16, 3);
    v2 << outer.v, b.v;
    Triangles f2(24, 3);
    f2 << outer.f, (b.f.array() + 8).matrix();
    f2.col(1).swap(f2.col(2));
    const Mesh m = make_mesh(v2, f2, "two shells");
    EXPECT_EQ(m.cleanup.flipped_faces, 24) << shift;
    EXPECT_NEAR(m.volume, 2.0, 1e-12) << shift;  // signed sum of the shells
  }
}

TEST(MeshOrientation, OpenBoxKeepsMajorityWindingAndReportsSurfaceCentroid) {
  const Eigen::Vector3d size(0.2, 0.1, 0.4);
  const TriMesh box = make_box(size);
  // Drop the +z face (rows of the two triangles whose corners all have z = size.z()).
  std::vector<int> rows;
  for (int i = 0; i < 12; ++i) {
    bool top = true;
    for (int k = 0; k < 3; ++k) top = top && box.v(box.f(i, k), 2) == size.z();
    if (!top) rows.push_back(i);
  }
  ASSERT_EQ(rows.size(), 10u);
  Triangles open(10, 3);
  for (int i = 0; i < 10; ++i) open.row(i) = box.f.row(rows[i]);
  Triangles some_flipped = open;
  for (int i : {0, 3, 9}) std::swap(some_flipped(i, 1), some_flipped(i, 2));

  const Mesh m = make_mesh(box.v, some_flipped, "open box");
  EXPECT_FALSE(m.closed);
  EXPECT_EQ(m.volume, 0.0);
  EXPECT_EQ(m.boundary_edges, 4);
  EXPECT_EQ(m.cleanup.flipped_faces, 3);
  EXPECT_EQ(m.faces, open);
  // Area-weighted centroid of the five faces, by hand: bottom (0.2x0.1 at z=0), four walls.
  const double a = size.x(), b = size.y(), c = size.z();
  const double area = a * b + 2 * a * c + 2 * b * c;
  EXPECT_NEAR(m.area, area, 1e-12);
  const Eigen::Vector3d centroid =
      (a * b * Eigen::Vector3d(a / 2, b / 2, 0) + a * c * Eigen::Vector3d(a / 2, 0, c / 2) +
       a * c * Eigen::Vector3d(a / 2, b, c / 2) + b * c * Eigen::Vector3d(0, b / 2, c / 2) +
       b * c * Eigen::Vector3d(a, b / 2, c / 2)) /
      area;
  EXPECT_LT((m.center_of_mass - centroid).norm(), 1e-12);
}

TEST(MeshOrientation, IcosphereVolumeWithinDiscretisationBounds) {
  const double r = 0.07;
  const Eigen::Vector3d centre(0.5, -0.3, 0.2);
  TriMesh s = make_icosphere(3, r, centre);
  // Rotate the whole sphere by a random rotation about its centre and reverse a random half of
  // the faces: neither may change the answer.
  std::mt19937 rng(7);
  const Eigen::Matrix3d rot =
      Eigen::Quaterniond(Eigen::Vector4d::NullaryExpr([&](Eigen::Index) { return std::normal_distribution<>()(rng); }))
          .normalized()
          .toRotationMatrix();
  for (Eigen::Index i = 0; i < s.v.rows(); ++i) s.v.row(i) = (centre + rot * (s.v.row(i).transpose() - centre)).transpose();
  const Triangles outward = s.f;
  int reversed = 0;
  for (Eigen::Index i = 0; i < s.f.rows(); ++i)
    if (rng() % 2) {
      std::swap(s.f(i, 1), s.f(i, 2));
      ++reversed;
    }
  const Mesh m = make_mesh(s.v, s.f, "icosphere");
  ASSERT_EQ(m.faces.rows(), 20 * 64);
  EXPECT_TRUE(m.closed);
  EXPECT_EQ(m.cleanup.flipped_faces, reversed);
  EXPECT_EQ(m.faces, outward);

  // Independent: sum of pyramids from the centre, area * height / 3, and the sphere bounds:
  // inscribed polyhedron lies between the ball of its smallest face distance and the ball of r.
  double pyramids = 0.0, area = 0.0, r_in = r;
  for (Eigen::Index f = 0; f < s.f.rows(); ++f) {
    const Eigen::Vector3d a = s.v.row(outward(f, 0)), b = s.v.row(outward(f, 1)), c = s.v.row(outward(f, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a);
    const double fa = 0.5 * n.norm();
    const double h = n.normalized().dot(a - centre);
    ASSERT_GT(h, 0.0);
    pyramids += fa * h / 3.0;
    area += fa;
    r_in = std::min(r_in, h);
  }
  EXPECT_NEAR(m.volume, pyramids, 1e-12 * pyramids);
  EXPECT_NEAR(m.area, area, 1e-12 * area);
  EXPECT_GT(m.volume, 4.0 / 3.0 * kPi * std::pow(r_in, 3));
  EXPECT_LT(m.volume, 4.0 / 3.0 * kPi * std::pow(r, 3));
  EXPECT_NEAR(m.volume, 4.0 / 3.0 * kPi * std::pow(r, 3), 0.02 * 4.0 / 3.0 * kPi * std::pow(r, 3));
  EXPECT_LT((m.center_of_mass - centre).norm(), 1e-12);  // centrally symmetric polyhedron
}

// ------------------------------------------------------------------------------ clean-up

TEST(MeshCleanup, DegenerateAndDuplicateFacesAreRemovedAndCounted) {
  const TriMesh box = make_box(Eigen::Vector3d(1, 1, 1));
  Points v(10, 3);
  v << box.v, 0.5, 0.0, 0.0,  // 8: middle of edge 0-1, used only by a collinear triangle
      9.0, 9.0, 9.0;          // 9: used by nobody
  Triangles f(16, 3);
  f.topRows(12) = box.f;
  f.row(12) << 0, 0, 1;                            // repeated index
  f.row(13) << 0, 8, 1;                            // collinear
  f.row(14) << box.f(3, 1), box.f(3, 2), box.f(3, 0);  // face 3 rotated
  f.row(15) << box.f(5, 2), box.f(5, 1), box.f(5, 0);  // face 5 reversed
  Triangles shuffled = f;
  // Put a duplicate before its original: the first occurrence is the one kept.
  shuffled.row(0) = f.row(15);
  shuffled.row(15) = f.row(0);
  const Mesh m = make_mesh(v, f, "dirty");
  EXPECT_EQ(m.cleanup.degenerate_faces, 2);
  EXPECT_EQ(m.cleanup.duplicate_faces, 2);
  EXPECT_EQ(m.cleanup.unused_vertices, 2);
  EXPECT_EQ(m.cleanup.welded_vertices, 0);
  EXPECT_EQ(m.cleanup.flipped_faces, 0);
  EXPECT_EQ(m.vertices, box.v);
  EXPECT_EQ(m.faces, box.f);
  EXPECT_TRUE(m.closed);
  EXPECT_NEAR(m.volume, 1.0, 1e-12);

  const Mesh s = make_mesh(v, shuffled, "dirty, shuffled");
  EXPECT_EQ(s.cleanup.duplicate_faces, 2);
  EXPECT_EQ(s.faces.rows(), 12);
  // The first occurrence of a triple is kept, here face 5 reversed, and it is turned outward.
  EXPECT_EQ(s.cleanup.flipped_faces, 1);
  // Flipping swaps the last two corners: (c, b, a) becomes (c, a, b), a rotation of face 5.
  EXPECT_EQ(s.faces.row(0), Eigen::RowVector3i(f(15, 0), f(15, 2), f(15, 1)));
  EXPECT_EQ(s.faces.row(0), Eigen::RowVector3i(box.f(5, 2), box.f(5, 0), box.f(5, 1)));
  EXPECT_NEAR(s.volume, 1.0, 1e-12);
}

TEST(MeshCleanup, WeldingFindsNeighboursAcrossCellBoundaries) {
  // A cube with a corner at the origin stored as 36 separate corners, each jittered by less
  // than the weld tolerance in random directions: the copies of the corners on the coordinate
  // planes straddle the boundaries of any grid anchored at zero.
  const double side = 1.0;
  const TriMesh box = make_box(Eigen::Vector3d::Constant(side));
  const double tol = 1e-9 * std::sqrt(3.0) * side;  // default tolerance times the diagonal
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jitter(-0.2 * tol, 0.2 * tol);
  Points v(36, 3);
  Triangles f(12, 3);
  for (int i = 0; i < 12; ++i)
    for (int k = 0; k < 3; ++k) {
      v.row(3 * i + k) = box.v.row(box.f(i, k));
      for (int d = 0; d < 3; ++d) v(3 * i + k, d) += jitter(rng);
      f(i, k) = 3 * i + k;
    }
  const Mesh m = make_mesh(v, f, "jittered");
  EXPECT_EQ(m.vertices.rows(), 8);
  EXPECT_EQ(m.cleanup.welded_vertices, 28);
  EXPECT_TRUE(m.closed);
  EXPECT_NEAR(m.volume, 1.0, 1e-7);

  MeshLoadOptions exact;
  exact.weld_tolerance = 0.0;
  const Mesh e = make_mesh(v, f, "jittered, exact weld", exact);
  EXPECT_EQ(e.vertices.rows(), 36);
  EXPECT_FALSE(e.closed);
  EXPECT_EQ(e.volume, 0.0);

  // Points farther apart than the tolerance stay apart.
  MeshLoadOptions coarse;
  coarse.weld_tolerance = 1e-3;
  Points w = box.v;
  Points w2(9, 3);
  w2 << w, w.row(7) + Eigen::RowVector3d(2e-3, 0, 0) * std::sqrt(3.0);  // 2x the tolerance away
  Triangles f2(13, 3);
  f2 << box.f, 8, 5, 6;
  const Mesh c = make_mesh(w2, f2, "coarse", coarse);
  EXPECT_EQ(c.vertices.rows(), 9);
  EXPECT_EQ(c.cleanup.welded_vertices, 0);
}

TEST(MeshCleanup, NegativeZeroWeldsWithZero) {
  const TriMesh box = make_box(Eigen::Vector3d::Constant(1.0));
  Points v(9, 3);
  v << box.v, -0.0, -0.0, -0.0;  // a copy of corner 0
  Triangles f = box.f;
  for (int i = 0; i < 12; ++i)
    for (int k = 0; k < 3; ++k)
      if (f(i, k) == 0 && i % 2 == 0) f(i, k) = 8;
  MeshLoadOptions exact;
  exact.weld_tolerance = 0.0;
  const Mesh m = make_mesh(v, f, "signed zero", exact);
  EXPECT_EQ(m.vertices.rows(), 8);
  EXPECT_EQ(m.cleanup.welded_vertices, 1);
  EXPECT_TRUE(m.closed);
}

TEST(MeshCleanup, FaceNormalsAreUnitAndOutward) {
  const Eigen::Vector3d size(1, 2, 3);
  const Mesh m = make_mesh(make_box(size).v, make_box(size).f);
  const Points n = m.face_normals();
  ASSERT_EQ(n.rows(), 12);
  for (int f = 0; f < 12; ++f) {
    EXPECT_NEAR(n.row(f).norm(), 1.0, 1e-15);
    EXPECT_NEAR(n.row(f).cwiseAbs().maxCoeff(), 1.0, 1e-15);  // an axis direction
    EXPECT_EQ(n.row(f), m.face_normal(f).transpose());
  }
  double area = 0.0;
  for (int f = 0; f < 12; ++f) area += m.face_area(f);
  EXPECT_NEAR(area, 22.0, 1e-12);
  expect_invalid_argument([&] { m.face_normal(12); }, "out of range");
  expect_invalid_argument([&] { m.face_area(-1); }, "out of range");
}

// ------------------------------------------------------------------------------ bad input

TEST(MeshErrors, MakeMeshRejectsBadArrays) {
  const TriMesh box = make_box(Eigen::Vector3d::Constant(1.0));
  Triangles bad = box.f;
  bad(4, 2) = 8;
  expect_invalid_argument([&] { make_mesh(box.v, bad, "cubeA"); }, "faces: face 4 has index 8 out of range [0, 8)");
  bad(4, 2) = -1;
  expect_invalid_argument([&] { make_mesh(box.v, bad, "cubeA"); }, "cubeA");
  Points nan = box.v;
  nan(3, 1) = std::nan("");
  expect_invalid_argument([&] { make_mesh(nan, box.f, "cubeB"); }, "vertices: vertex 3 is not finite");
  nan(3, 1) = INFINITY;
  expect_invalid_argument([&] { make_mesh(nan, box.f, "cubeB"); }, "cubeB");
  expect_invalid_argument([&] { make_mesh(box.v, Triangles(0, 3), "empty"); }, "no triangles");
  Triangles all_degenerate(2, 3);
  all_degenerate << 0, 0, 1, 2, 2, 2;
  expect_invalid_argument([&] { make_mesh(box.v, all_degenerate, "flat"); }, "no triangles");
  MeshLoadOptions o;
  for (double s : {0.0, -1.0, std::nan(""), double(INFINITY)}) {
    o.scale = s;
    expect_invalid_argument([&] { make_mesh(box.v, box.f, "x", o); }, "scale");
  }
  o.scale = 1.0;
  o.weld_tolerance = -1e-9;
  expect_invalid_argument([&] { make_mesh(box.v, box.f, "x", o); }, "weld_tolerance");
}

TEST_F(MeshFiles, BadFilesThrowFileErrorNamingTheFile) {
  const std::string missing = file("does-not-exist.stl");
  expect_file_error([&] { load_mesh(missing); }, missing, "not found");

  write_text(file("empty.stl"), "");
  expect_file_error([&] { load_mesh(file("empty.stl")); }, file("empty.stl"), "empty");

  std::mt19937 rng(11);
  std::string noise(333, '\0');
  for (char& c : noise) c = static_cast<char>(rng() & 0xFF);
  write_text(file("garbage.stl"), noise);
  expect_file_error([&] { load_mesh(file("garbage.stl")); }, file("garbage.stl"));
  write_text(file("garbage.obj"), "this is not a mesh\n");
  expect_file_error([&] { load_mesh(file("garbage.obj")); }, file("garbage.obj"));
  write_text(file("notes.xyz123"), "hello\n");
  expect_file_error([&] { load_mesh(file("notes.xyz123")); }, file("notes.xyz123"));
  expect_file_error([&] { load_mesh(dir_.string()); }, dir_.string(), "directory");

  // Parsed, but nothing to grasp: no facets; only a line.
  write_text(file("nofacets.stl"), "solid t\nendsolid t\n");
  expect_file_error([&] { load_mesh(file("nofacets.stl")); }, file("nofacets.stl"), "no triangles");
  write_text(file("line.obj"), "v 0 0 0\nv 1 0 0\nl 1 2\n");
  expect_file_error([&] { load_mesh(file("line.obj")); }, file("line.obj"), "no triangles");

  // Malformed contents.
  write_text(file("nan.stl"),
             "solid t\nfacet normal 0 0 1\nouter loop\nvertex nan 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
             "endloop\nendfacet\nendsolid t\n");
  expect_file_error([&] { load_mesh(file("nan.stl")); }, file("nan.stl"), "not finite");
  TriMesh box = make_box(Eigen::Vector3d::Constant(1.0));
  box.v(2, 0) = std::nan("");
  write_binary_stl(file("nan_binary.stl"), box);
  expect_file_error([&] { load_mesh(file("nan_binary.stl")); }, file("nan_binary.stl"), "not finite");
  write_text(file("bad_index.ply"),
             "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
             "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
  expect_file_error([&] { load_mesh(file("bad_index.ply")); }, file("bad_index.ply"), "out of range");
  write_dae(file("bad_unit.dae"), make_box(Eigen::Vector3d::Constant(1.0)), "Z_UP", "meter=\"abc\"");
  expect_file_error([&] { load_mesh(file("bad_unit.dae")); }, file("bad_unit.dae"), "unit");
  write_dae(file("zero_unit.dae"), make_box(Eigen::Vector3d::Constant(1.0)), "Z_UP", "meter=\"0\"");
  expect_file_error([&] { load_mesh(file("zero_unit.dae")); }, file("zero_unit.dae"), "unit");

  MeshLoadOptions o;
  o.scale = -2.0;
  expect_invalid_argument([&] { load_mesh(missing, o); }, "scale");
}

TEST_F(MeshFiles, MalformedPlyIsReportedNotHungOrAborted) {
  // assimp 5.2 hangs on the first two and aborts the process on the third.
  write_ply_polys(file("full.ply"), make_l_prism(1.0, 1.0), "ascii");
  const std::string full = read_text(file("full.ply"));
  const std::size_t body = full.find("end_header\n") + 11;
  write_text(file("cut_header.ply"), full.substr(0, full.find("end_header")));
  expect_file_error([&] { load_mesh(file("cut_header.ply")); }, file("cut_header.ply"), "end_header");
  write_text(file("bad_header.ply"), full.substr(0, 120) + "x" + full.substr(120));
  expect_file_error([&] { load_mesh(file("bad_header.ply")); }, file("bad_header.ply"), "header line");
  write_text(file("cut_body.ply"), full.substr(0, body + (full.size() - body) / 2));
  expect_file_error([&] { load_mesh(file("cut_body.ply")); }, file("cut_body.ply"), "ends early");
  write_ply_polys(file("full_bin.ply"), make_l_prism(1.0, 1.0), "binary_little_endian");
  const std::string bin = read_text(file("full_bin.ply"));
  write_text(file("cut_bin.ply"), bin.substr(0, bin.size() - 20));
  expect_file_error([&] { load_mesh(file("cut_bin.ply")); }, file("cut_bin.ply"), "ends early");

  // Found by fuzzing: a first line "ply\0" is not PLY magic to a strict reader, and assimp's PLY
  // importer, which took the file, hung on it; every .ply file and anything starting with "ply"
  // is pairgrasp's reader's, and this is refused at once.
  write_text(file("nul_magic.ply"), std::string("ply\0\n", 5) + full.substr(4));
  expect_file_error([&] { load_mesh(file("nul_magic.ply")); }, file("nul_magic.ply"), "not a PLY file");
  write_text(file("nul_magic.obj"), std::string("ply\0\n", 5) + full.substr(4));
  expect_file_error([&] { load_mesh(file("nul_magic.obj")); }, file("nul_magic.obj"), "not a PLY file");

  std::string huge = full;
  huge.replace(huge.find("element face 8"), 14, "element face 9999999999999");
  write_text(file("huge.ply"), huge);
  expect_file_error([&] { load_mesh(file("huge.ply")); }, file("huge.ply"), "more than the file holds");
  std::string two = full;
  two.replace(two.find("\n1 6 5 4 3 2 1 0"), 16, "\n1 2 5 4");
  write_text(file("two.ply"), two);
  expect_file_error([&] { load_mesh(file("two.ply")); }, file("two.ply"), "needs 3");
  std::string word = full;
  word.replace(word.find("\n1 6 5 4 3 2 1 0") + 3, 1, "six");
  write_text(file("word.ply"), word);
  expect_file_error([&] { load_mesh(file("word.ply")); }, file("word.ply"), "'six' is not an integer");
  std::string range = full;
  range.replace(range.find("\n1 6 5 4 3 2 1 0"), 16, "\n1 6 5 4 3 2 1 12");
  write_text(file("range.ply"), range);
  expect_file_error([&] { load_mesh(file("range.ply")); }, file("range.ply"), "out of range");
}

TEST_F(MeshFiles, MalformedColladaIsReportedNotHungOrCrashed) {
  // Each of these hangs or crashes assimp 5.2 when it is handed the file unchecked.
  write_dae(file("ok.dae"), make_box(Eigen::Vector3d::Constant(1.0)), "Z_UP", "meter=\"1\"");
  const std::string ok = read_text(file("ok.dae"));
  std::string letter = ok;
  const std::size_t p = letter.find("<p>");
  letter.replace(letter.find(' ', p + 6), 1, " x");
  write_text(file("letter.dae"), letter);
  expect_file_error([&] { load_mesh(file("letter.dae")); }, file("letter.dae"), "<p> index list");
  std::string no_count = ok;
  no_count.replace(no_count.find(" count=\"24\""), 11, "");
  write_text(file("no_count.dae"), no_count);
  expect_file_error([&] { load_mesh(file("no_count.dae")); }, file("no_count.dae"), "no count attribute");
  std::string cycle = ok;
  cycle.replace(cycle.find("<instance_geometry url=\"#g\"/>"), 0, "<node id=\"inner\"><instance_node url=\"#n0\"/></node>");
  write_text(file("cycle.dae"), cycle);
  expect_file_error([&] { load_mesh(file("cycle.dae")); }, file("cycle.dae"), "cycle");
  // Commented-out garbage is not looked at.
  std::string commented = ok;
  commented.replace(commented.find("<library_geometries>"), 0, "<!-- <p>not an index</p> <float_array/> -->");
  write_text(file("commented.dae"), commented);
  EXPECT_EQ(load_mesh(file("commented.dae")).faces.rows(), 12);
  // A binary STL cut short.
  write_binary_stl(file("cut.stl"), make_box(Eigen::Vector3d::Constant(1.0)));
  const std::string stl = read_text(file("cut.stl"));
  write_text(file("cut.stl"), stl.substr(0, stl.size() - 30));
  expect_file_error([&] { load_mesh(file("cut.stl")); }, file("cut.stl"));
}

TEST_F(MeshFiles, MutatedFilesLoadOrThrowFileError) {
  // Bounded fuzzing: random byte changes, insertions, deletions and truncations of a valid file
  // of each format must give a valid mesh or a FileError, never a crash, hang or other error.
  const TriMesh box = make_box(Eigen::Vector3d(0.1, 0.2, 0.3), Eigen::Vector3d(0.01, 0.02, 0.03));
  write_binary_stl(file("seed.stl"), box);
  write_ascii_stl(file("seed_ascii.stl"), box);
  write_obj_box_quads(file("seed.obj"), box);
  write_ply_polys(file("seed.ply"), make_l_prism(0.01, 0.02), "ascii");
  write_ply_polys(file("seed_bin.ply"), make_l_prism(0.01, 0.02), "binary_big_endian");
  write_dae(file("seed.dae"), box, "Z_UP", "meter=\"0.01\"");
  std::mt19937 rng(2024);
  const char* tokens[] = {"-1", "nan", "1e400", "4294967296", "0", "<", ">", "\"", " ", "\n", "f", "v", "<p>", "count=\"7\""};
  int loaded = 0, rejected = 0;
  for (const std::string name : {"seed.stl", "seed_ascii.stl", "seed.obj", "seed.ply", "seed_bin.ply", "seed.dae"}) {
    const std::string original = read_text(file(name));
    const std::string ext = fs::path(name).extension().string();
    for (int round = 0; round < 60; ++round) {
      std::string s = original;
      switch (rng() % 4) {
        case 0:
          for (unsigned k = 0, n = 1 + rng() % 6; k < n; ++k) s[rng() % s.size()] = static_cast<char>(rng() & 0xFF);
          break;
        case 1: s.resize(rng() % s.size()); break;
        case 2: s.insert(rng() % s.size(), tokens[rng() % (sizeof tokens / sizeof *tokens)]); break;
        default: s.erase(rng() % s.size(), 1 + rng() % 20); break;
      }
      const std::string path = file("mutant" + ext);
      write_text(path, s);
      try {
        const Mesh m = load_mesh(path);
        ++loaded;
        ASSERT_GT(m.faces.rows(), 0);
        ASSERT_TRUE(m.vertices.allFinite());
        ASSERT_GE(m.faces.minCoeff(), 0);
        ASSERT_LT(m.faces.maxCoeff(), m.vertices.rows());
      } catch (const FileError& e) {
        ++rejected;
        ASSERT_NE(std::string(e.what()).find(path), std::string::npos);
      } catch (const std::exception& e) {
        FAIL() << name << " round " << round << ": " << e.what();
      }
    }
  }
  EXPECT_GT(loaded, 0);
  EXPECT_GT(rejected, 0);
}

// ------------------------------------------------------------------------------ units

TEST(TargetScale, MillimetresAreRefusedNamingTheScaleThatFixesThem) {
  const double span = 0.19;  // the Barrett hand's d_max
  const Eigen::Vector3d mug(0.125, 0.081, 0.103);
  const Mesh metres = make_mesh(make_box(mug).v, make_box(mug).f, "mug");
  EXPECT_EQ(pairgrasp::suggest_target_scale(metres, span), 1.0);
  EXPECT_NO_THROW(pairgrasp::check_target_scale(metres, span));
  const Mesh mm = make_mesh(make_box(mug * 1000.0).v, make_box(mug * 1000.0).f, "mug_mm");
  EXPECT_DOUBLE_EQ(pairgrasp::suggest_target_scale(mm, span), 1e-3);
  try {
    pairgrasp::check_target_scale(mm, span);
    FAIL() << "a mug in millimetres was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("mug_mm: "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("millimetres? Load it with scale=0.001 (CLI: --scale 0.001), which makes it "
                                         "0.125 m across"), std::string::npos) << e.what();
  }
  const Mesh tiny = make_mesh(make_box(mug / 1000.0).v, make_box(mug / 1000.0).f, "mug_km");
  EXPECT_DOUBLE_EQ(pairgrasp::suggest_target_scale(tiny, span), 1e3);
  EXPECT_THROW(pairgrasp::check_target_scale(tiny, span), std::invalid_argument);
}
