// URDF reading for pairgrasp::Hand: the kinematic tree (urdfdom) and the link geometry.
#include "hand_impl.hpp"

#include <pairgrasp/error.hpp>

#include <console_bridge/console.h>
#include <tinyxml.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <set>
#include <sstream>

namespace fs = std::filesystem;

namespace pairgrasp {
namespace hand_detail {
namespace {

/// Collects urdfdom's console messages while a URDF is parsed, so that they reach the error.
class CaptureOutput : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_WARN) messages.push_back(text);
  }
  std::vector<std::string> messages;
};

std::string join(const std::vector<std::string>& items, const std::string& sep) {
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i) out += (i ? sep : "") + items[i];
  return out;
}

std::string read_text(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw FileError(path, "URDF file not found");
  if (fs::is_directory(path, ec)) throw FileError(path, "is a directory, not a URDF file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path, "cannot open URDF file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

urdf::ModelInterfaceSharedPtr parse(const std::string& path, const std::string& xml) {
  static std::mutex console_mutex;  // console_bridge's handler is process-wide
  std::lock_guard<std::mutex> lock(console_mutex);
  CaptureOutput capture;
  console_bridge::OutputHandler* previous = console_bridge::getOutputHandler();
  console_bridge::useOutputHandler(&capture);
  urdf::ModelInterfaceSharedPtr model;
  std::string exception_text;
  try {
    model = urdf::parseURDF(xml);
  } catch (const std::exception& e) {
    exception_text = e.what();
  }
  console_bridge::useOutputHandler(previous);
  if (!model) {
    std::vector<std::string> why = capture.messages;
    if (!exception_text.empty()) why.push_back(exception_text);
    throw FileError(path, "malformed URDF" + (why.empty() ? std::string() : ": " + join(why, "; ")));
  }
  return model;
}

/// Joint names in the order of their <joint> elements.
std::vector<std::string> joint_order(const std::string& xml) {
  std::vector<std::string> order;
  TiXmlDocument doc;
  doc.Parse(xml.c_str());
  const TiXmlElement* robot = doc.FirstChildElement("robot");
  if (!robot) return order;
  for (const TiXmlElement* j = robot->FirstChildElement("joint"); j; j = j->NextSiblingElement("joint"))
    if (const char* name = j->Attribute("name")) order.emplace_back(name);
  return order;
}

Pose to_pose(const urdf::Pose& p) {
  Pose T = Pose::Identity();
  T.translation() = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
  Eigen::Quaterniond q(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z);
  if (q.norm() > 0) T.linear() = q.normalized().toRotationMatrix();
  return T;
}

bool finite(const urdf::Pose& p) {
  return std::isfinite(p.position.x) && std::isfinite(p.position.y) && std::isfinite(p.position.z) &&
         std::isfinite(p.rotation.x) && std::isfinite(p.rotation.y) && std::isfinite(p.rotation.z) &&
         std::isfinite(p.rotation.w);
}

/// Resolves a mesh filename of `link` to a path on disk (not checked for existence unless the
/// resolution itself needs it).
std::string resolve_mesh(const std::string& filename, const std::string& urdf_path,
                         const std::string& link, const std::vector<std::string>& package_paths) {
  const fs::path urdf_dir = fs::path(urdf_path).parent_path();
  const std::string package_prefix = "package://";
  const std::string file_prefix = "file://";
  if (filename.rfind(package_prefix, 0) == 0) {
    const std::string rest = filename.substr(package_prefix.size());
    const auto slash = rest.find('/');
    if (slash == std::string::npos || slash == 0 || slash + 1 >= rest.size())
      throw FileError(urdf_path, "link '" + link + "': mesh URI '" + filename +
                                     "' is not of the form package://NAME/PATH");
    const std::string package = rest.substr(0, slash);
    const std::string inside = rest.substr(slash + 1);
    std::error_code ec;
    std::string found_package_dir;
    for (const std::string& dir : package_paths) {
      const fs::path d(dir);
      const fs::path candidates[2] = {d / package, d.filename() == package ? d : fs::path()};
      for (const fs::path& pkg : candidates) {
        if (pkg.empty() || !fs::is_directory(pkg, ec)) continue;
        const fs::path file = pkg / inside;
        if (fs::exists(file, ec)) return file.lexically_normal().string();
        if (found_package_dir.empty()) found_package_dir = pkg.lexically_normal().string();
      }
    }
    if (!found_package_dir.empty())  // the package exists, the file does not: a missing mesh
      throw FileError((fs::path(found_package_dir) / inside).string(),
                      "mesh of link '" + link + "' (" + filename + " in " + urdf_path + "): file not found");
    throw FileError(urdf_path, "link '" + link + "': cannot resolve '" + filename + "': no package '" +
                                   package + "' in the package search path [" + join(package_paths, ", ") +
                                   "] (HandLoadOptions::package_paths, then the spec's \"package_paths\")");
  }
  std::string path = filename;
  if (path.rfind(file_prefix, 0) == 0) path = path.substr(file_prefix.size());
  if (path.empty()) throw FileError(urdf_path, "link '" + link + "': empty mesh filename");
  fs::path p(path);
  if (p.is_relative()) p = urdf_dir / p;
  return p.lexically_normal().string();
}

/// Appends a mesh (transformed by T, scaled by s per axis first) to a vertex/face soup.
void append(const Mesh& m, const Eigen::Vector3d& s, const Pose& T, std::vector<Eigen::Vector3d>& V,
            std::vector<Eigen::Vector3i>& F) {
  const int base = static_cast<int>(V.size());
  for (Eigen::Index i = 0; i < m.vertices.rows(); ++i) {
    const Eigen::Vector3d v = m.vertices.row(i).transpose().cwiseProduct(s);
    V.push_back(T * v);
  }
  const bool mirror = s.prod() < 0;  // a mirroring scale turns the winding inside out
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f) {
    Eigen::Vector3i t(m.faces(f, 0), m.faces(f, 1), m.faces(f, 2));
    if (mirror) std::swap(t[1], t[2]);
    F.push_back(t.array() + base);
  }
}

Mesh from_soup(const std::vector<Eigen::Vector3d>& V, const std::vector<Eigen::Vector3i>& F,
               const std::string& name) {
  Points P(static_cast<Eigen::Index>(V.size()), 3);
  for (std::size_t i = 0; i < V.size(); ++i) P.row(static_cast<Eigen::Index>(i)) = V[i].transpose();
  Triangles T(static_cast<Eigen::Index>(F.size()), 3);
  for (std::size_t i = 0; i < F.size(); ++i) T.row(static_cast<Eigen::Index>(i)) = F[i].transpose();
  return make_mesh(P, T, name);
}

/// Strips the "<path>: " prefix FileError puts before its message.
std::string bare_message(const FileError& e) {
  const std::string what = e.what();
  const std::string prefix = e.path() + ": ";
  return what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what;
}

/// Geometry of one link: its collision elements, else its visual elements, merged.
bool link_geometry(const urdf::Link& link, const std::string& urdf_path,
                   const std::vector<std::string>& package_paths, Mesh& out) {
  struct Element {
    urdf::GeometrySharedPtr geometry;
    urdf::Pose origin;
  };
  std::vector<Element> elements;
  for (const auto& c : link.collision_array)
    if (c && c->geometry) elements.push_back({c->geometry, c->origin});
  if (elements.empty() && link.collision && link.collision->geometry)
    elements.push_back({link.collision->geometry, link.collision->origin});
  if (elements.empty()) {
    for (const auto& v : link.visual_array)
      if (v && v->geometry) elements.push_back({v->geometry, v->origin});
    if (elements.empty() && link.visual && link.visual->geometry)
      elements.push_back({link.visual->geometry, link.visual->origin});
  }
  if (elements.empty()) return false;

  const std::string where = "link '" + link.name + "'";
  std::vector<Eigen::Vector3d> V;
  std::vector<Eigen::Vector3i> F;
  std::string source = urdf_path + "#" + link.name;
  for (const Element& el : elements) {
    if (!finite(el.origin)) throw FileError(urdf_path, where + ": geometry <origin> is not finite");
    const Pose T = to_pose(el.origin);
    const urdf::Geometry& g = *el.geometry;
    Eigen::Vector3d scale(1, 1, 1);
    Mesh part;
    switch (g.type) {
      case urdf::Geometry::BOX: {
        const auto& b = static_cast<const urdf::Box&>(g);
        const Eigen::Vector3d size(b.dim.x, b.dim.y, b.dim.z);
        if (!(size.array() > 0).all() || !size.allFinite())
          throw FileError(urdf_path, where + ": <box size> must be three positive lengths");
        part = box_mesh(size, source);
        break;
      }
      case urdf::Geometry::CYLINDER: {
        const auto& c = static_cast<const urdf::Cylinder&>(g);
        if (!(c.radius > 0) || !(c.length > 0) || !std::isfinite(c.radius) || !std::isfinite(c.length))
          throw FileError(urdf_path, where + ": <cylinder> radius and length must be positive");
        part = cylinder_mesh(c.radius, c.length, source);
        break;
      }
      case urdf::Geometry::SPHERE: {
        const auto& s = static_cast<const urdf::Sphere&>(g);
        if (!(s.radius > 0) || !std::isfinite(s.radius))
          throw FileError(urdf_path, where + ": <sphere> radius must be positive");
        part = sphere_mesh(s.radius, source);
        break;
      }
      case urdf::Geometry::MESH: {
        const auto& m = static_cast<const urdf::Mesh&>(g);
        scale = Eigen::Vector3d(m.scale.x, m.scale.y, m.scale.z);
        if (!scale.allFinite() || (scale.array() == 0).any())
          throw FileError(urdf_path, where + ": mesh scale must be three non-zero numbers");
        const std::string path = resolve_mesh(m.filename, urdf_path, link.name, package_paths);
        std::error_code ec;
        if (!fs::exists(path, ec))
          throw FileError(path, "mesh of link '" + link.name + "' (" + urdf_path + "): file not found");
        try {
          part = load_mesh(path);
        } catch (const FileError& e) {
          throw FileError(e.path(), "mesh of link '" + link.name + "' (" + urdf_path + "): " + bare_message(e));
        }
        if (elements.size() == 1) source = path;
        break;
      }
      default:
        throw FileError(urdf_path, where + ": unsupported geometry type");
    }
    append(part, scale, T, V, F);
  }
  try {
    out = from_soup(V, F, source);
  } catch (const std::invalid_argument& e) {
    throw FileError(urdf_path, where + ": invalid geometry: " + e.what());
  }
  return true;
}

const char* type_name(int type) {
  switch (type) {
    case urdf::Joint::FLOATING: return "floating";
    case urdf::Joint::PLANAR: return "planar";
    default: return "unknown";
  }
}

}  // namespace

KModel load_urdf(const std::string& urdf_path, const std::vector<std::string>& package_paths,
                 const std::string& wrist_link) {
  const std::string xml = read_text(urdf_path);
  const urdf::ModelInterfaceSharedPtr model = parse(urdf_path, xml);
  if (!model->getRoot()) throw FileError(urdf_path, "malformed URDF: no root link");
  // The hand is the wrist's subtree: what lies above it (a robot's arm, a mount) is not read.
  const urdf::LinkConstSharedPtr root = model->getLink(wrist_link);
  if (!root) throw BadWrist("no link '" + wrist_link + "'");

  // Child joints in file order (urdfdom keeps them sorted by name).
  const std::vector<std::string> order = joint_order(xml);
  std::map<std::string, std::size_t> rank;
  for (std::size_t i = 0; i < order.size(); ++i) rank.emplace(order[i], i);
  auto rank_of = [&](const std::string& name) {
    auto it = rank.find(name);
    return it == rank.end() ? order.size() : it->second;
  };

  KModel km;
  km.urdf_path = urdf_path;
  km.robot_name = model->getName();

  std::function<void(const urdf::LinkConstSharedPtr&, int)> visit = [&](const urdf::LinkConstSharedPtr& link,
                                                                       int parent_joint) {
    if (km.link_index.count(link->name)) throw FileError(urdf_path, "link '" + link->name + "' appears twice");
    const int li = static_cast<int>(km.links.size());
    km.links.push_back({link->name, parent_joint, -1});
    km.link_index[link->name] = li;
    if (link->inertial) {
      const urdf::Inertial& in = *link->inertial;
      HandInertial& hi = km.links[li].inertial;
      const std::string where = "link '" + link->name + "': <inertial>";
      if (!finite(in.origin)) throw FileError(urdf_path, where + ": <origin> is not finite");
      hi.frame = to_pose(in.origin);
      hi.mass = in.mass;
      hi.inertia << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
      if (!std::isfinite(hi.mass) || hi.mass < 0.0 || !hi.inertia.allFinite())
        throw FileError(urdf_path, where + ": <mass> and <inertia> must be finite, mass >= 0");
      hi.present = true;
    }
    Mesh mesh;
    if (link_geometry(*link, urdf_path, package_paths, mesh)) {
      km.links[li].geometry = static_cast<int>(km.geometry.size());
      HandLink hl;
      hl.name = link->name;
      hl.mesh = std::move(mesh);
      km.geometry.push_back(std::move(hl));
    }
    std::vector<urdf::JointSharedPtr> children(link->child_joints.begin(), link->child_joints.end());
    std::stable_sort(children.begin(), children.end(),
                     [&](const auto& a, const auto& b) { return rank_of(a->name) < rank_of(b->name); });
    for (const auto& j : children) {
      KJoint kj;
      kj.name = j->name;
      kj.parent = li;
      const std::string where = "joint '" + j->name + "'";
      switch (j->type) {
        case urdf::Joint::FIXED: kj.type = KJoint::Fixed; break;
        case urdf::Joint::REVOLUTE: kj.type = KJoint::Revolute; break;
        case urdf::Joint::CONTINUOUS: kj.type = KJoint::Continuous; break;
        case urdf::Joint::PRISMATIC: kj.type = KJoint::Prismatic; break;
        default:
          throw FileError(urdf_path, where + ": type '" + type_name(j->type) +
                                         "' is not supported (revolute, continuous, prismatic, fixed are)");
      }
      if (!finite(j->parent_to_joint_origin_transform))
        throw FileError(urdf_path, where + ": <origin> is not finite");
      kj.origin = to_pose(j->parent_to_joint_origin_transform);
      if (kj.type != KJoint::Fixed) {
        const Eigen::Vector3d axis(j->axis.x, j->axis.y, j->axis.z);
        if (!axis.allFinite() || axis.norm() < 1e-12)
          throw FileError(urdf_path, where + ": <axis> must be a non-zero vector");
        kj.axis = axis.normalized();
      }
      if (j->limits && kj.type != KJoint::Fixed) {
        kj.effort = j->limits->effort;
        kj.velocity = j->limits->velocity;
        if (!std::isfinite(kj.effort) || !std::isfinite(kj.velocity) || kj.effort < 0.0 || kj.velocity < 0.0)
          throw FileError(urdf_path, where + ": <limit> effort and velocity must be finite and >= 0");
      }
      if (kj.type == KJoint::Revolute || kj.type == KJoint::Prismatic) {
        if (!j->limits) throw FileError(urdf_path, where + ": <limit> is required for this joint type");
        kj.limited = true;
        kj.lower = j->limits->lower;
        kj.upper = j->limits->upper;
        if (!std::isfinite(kj.lower) || !std::isfinite(kj.upper) || kj.lower > kj.upper)
          throw FileError(urdf_path, where + ": <limit> needs finite lower <= upper, got lower " +
                                         std::to_string(kj.lower) + ", upper " + std::to_string(kj.upper));
      }
      if (j->mimic && !j->mimic->joint_name.empty()) {
        if (kj.type == KJoint::Fixed) throw FileError(urdf_path, where + ": a fixed joint cannot <mimic>");
        kj.mimic_of = j->mimic->joint_name;
        kj.multiplier = j->mimic->multiplier;
        kj.offset = j->mimic->offset;
        if (!std::isfinite(kj.multiplier) || !std::isfinite(kj.offset))
          throw FileError(urdf_path, where + ": <mimic> multiplier and offset must be finite");
      }
      const int ji = static_cast<int>(km.joints.size());
      km.joint_index[kj.name] = ji;
      if (kj.type != KJoint::Fixed) {
        kj.value_index = static_cast<int>(km.movable.size());
        km.movable.push_back(ji);
      }
      km.joints.push_back(kj);
      const urdf::LinkConstSharedPtr child = model->getLink(j->child_link_name);
      if (!child) throw FileError(urdf_path, where + ": no child link '" + j->child_link_name + "'");
      km.joints[ji].child = static_cast<int>(km.links.size());
      visit(child, ji);
    }
  };
  visit(root, -1);

  // Mimic masters, and no cycles among them.
  for (KJoint& j : km.joints) {
    if (j.mimic_of.empty()) continue;
    auto it = km.joint_index.find(j.mimic_of);
    if (it == km.joint_index.end() && model->getJoint(j.mimic_of))
      throw BadWrist("joint '" + j.name + "' of the hand mimics joint '" + j.mimic_of + "', which is above link '" +
                     wrist_link + "' (not part of the hand)");
    if (it == km.joint_index.end())
      throw FileError(urdf_path, "joint '" + j.name + "': <mimic> names unknown joint '" + j.mimic_of + "'");
    if (km.joints[it->second].type == KJoint::Fixed)
      throw FileError(urdf_path, "joint '" + j.name + "': <mimic> names fixed joint '" + j.mimic_of + "'");
    j.mimic = it->second;
  }
  for (const KJoint& j : km.joints) {
    std::set<int> seen;
    int k = km.joint_index.at(j.name);
    while (k >= 0) {
      if (!seen.insert(k).second)
        throw FileError(urdf_path, "joint '" + j.name + "': <mimic> joints form a cycle");
      k = km.joints[k].mimic;
    }
  }
  return km;
}

// ------------------------------------------------------------------------------- primitives

namespace {
constexpr double kPi = 3.14159265358979323846;

Mesh finish(const std::vector<Eigen::Vector3d>& V, const std::vector<Eigen::Vector3i>& F,
            const std::string& name) {
  return from_soup(V, F, name);
}
}  // namespace

Mesh box_mesh(const Eigen::Vector3d& size, const std::string& name) {
  const Eigen::Vector3d h = size / 2;
  std::vector<Eigen::Vector3d> V;
  for (int i = 0; i < 8; ++i)
    V.emplace_back((i & 1) ? h.x() : -h.x(), (i & 2) ? h.y() : -h.y(), (i & 4) ? h.z() : -h.z());
  // Two counter-clockwise triangles per face, seen from outside.
  const std::vector<Eigen::Vector3i> F = {
      {0, 4, 6}, {0, 6, 2},  // -x
      {1, 3, 7}, {1, 7, 5},  // +x
      {0, 1, 5}, {0, 5, 4},  // -y
      {2, 6, 7}, {2, 7, 3},  // +y
      {0, 2, 3}, {0, 3, 1},  // -z
      {4, 5, 7}, {4, 7, 6},  // +z
  };
  return finish(V, F, name);
}

Mesh cylinder_mesh(double radius, double length, const std::string& name, int segments) {
  std::vector<Eigen::Vector3d> V;
  std::vector<Eigen::Vector3i> F;
  const double h = length / 2;
  for (int i = 0; i < segments; ++i) {
    const double a = 2 * kPi * i / segments;
    V.emplace_back(radius * std::cos(a), radius * std::sin(a), -h);
  }
  for (int i = 0; i < segments; ++i) V.emplace_back(V[i].x(), V[i].y(), h);
  const int cb = 2 * segments, ct = 2 * segments + 1;
  V.emplace_back(0, 0, -h);
  V.emplace_back(0, 0, h);
  for (int i = 0; i < segments; ++i) {
    const int j = (i + 1) % segments;
    F.emplace_back(i, j, segments + j);
    F.emplace_back(i, segments + j, segments + i);
    F.emplace_back(cb, j, i);
    F.emplace_back(ct, segments + i, segments + j);
  }
  return finish(V, F, name);
}

Mesh sphere_mesh(double radius, const std::string& name, int subdivisions) {
  // Icosphere: an icosahedron whose faces are split in four `subdivisions` times.
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> V = {{-1, t, 0}, {1, t, 0},  {-1, -t, 0}, {1, -t, 0},
                                    {0, -1, t}, {0, 1, t},  {0, -1, -t}, {0, 1, -t},
                                    {t, 0, -1}, {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  std::vector<Eigen::Vector3i> F = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                    {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                    {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                    {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (auto& v : V) v.normalize();
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      V.push_back((V[a] + V[b]).normalized());
      const int k = static_cast<int>(V.size()) - 1;
      mid.emplace(key, k);
      return k;
    };
    std::vector<Eigen::Vector3i> next;
    next.reserve(F.size() * 4);
    for (const auto& f : F) {
      const int a = midpoint(f[0], f[1]), b = midpoint(f[1], f[2]), c = midpoint(f[2], f[0]);
      next.emplace_back(f[0], a, c);
      next.emplace_back(f[1], b, a);
      next.emplace_back(f[2], c, b);
      next.emplace_back(a, b, c);
    }
    F.swap(next);
  }
  for (auto& v : V) v *= radius;
  return finish(V, F, name);
}

}  // namespace hand_detail
}  // namespace pairgrasp
