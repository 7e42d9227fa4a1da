// Hand::load(): the JSON hand spec, checked field by field, on top of the URDF model.
#include "hand_impl.hpp"

#include <pairgrasp/error.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <set>
#include <sstream>

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace pairgrasp {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kLimitTolerance = 1e-9;

std::string num(double x) {
  std::ostringstream ss;
  ss.precision(10);
  ss << x;
  return ss.str();
}

const char* type_of(const json& v) {
  if (v.is_null()) return "null";
  if (v.is_boolean()) return "a boolean";
  if (v.is_number()) return "a number";
  if (v.is_string()) return "a string";
  if (v.is_array()) return "an array";
  return "an object";
}

/// Reads typed fields of the spec; every failure names the spec file and the field.
class Spec {
 public:
  explicit Spec(std::string path) : path_(std::move(path)) {}

  [[noreturn]] void fail(const std::string& field, const std::string& message) const {
    throw FileError(path_, field + ": " + message);
  }

  void keys(const json& obj, const std::string& field, std::initializer_list<const char*> allowed) const {
    if (!obj.is_object()) fail(field, std::string("expected an object, got ") + type_of(obj));
    for (auto it = obj.begin(); it != obj.end(); ++it) {
      bool ok = it.key() == "comment" || it.key() == "description";
      for (const char* a : allowed) ok = ok || it.key() == a;
      if (!ok) {
        std::string list;
        for (const char* a : allowed) list += std::string(list.empty() ? "" : ", ") + a;
        fail(prefix(field) + it.key(), "unknown field (expected one of: " + list + ")");
      }
    }
  }

  static std::string prefix(const std::string& field) { return field.empty() ? "" : field + "."; }

  const json& require(const json& obj, const std::string& field, const char* key) const {
    auto it = obj.find(key);
    if (it == obj.end()) fail(prefix(field) + key, "missing field");
    return *it;
  }

  double number(const json& v, const std::string& field) const {
    if (!v.is_number()) fail(field, std::string("expected a number, got ") + type_of(v));
    const double x = v.get<double>();
    if (!std::isfinite(x)) fail(field, "expected a finite number");
    return x;
  }

  std::string string(const json& v, const std::string& field) const {
    if (!v.is_string()) fail(field, std::string("expected a string, got ") + type_of(v));
    std::string s = v.get<std::string>();
    if (s.empty()) fail(field, "must not be empty");
    return s;
  }

  const json& array(const json& v, const std::string& field, bool non_empty = true) const {
    if (!v.is_array()) fail(field, std::string("expected an array, got ") + type_of(v));
    if (non_empty && v.empty()) fail(field, "must not be empty");
    return v;
  }

  Eigen::Vector3d vec3(const json& v, const std::string& field, bool non_zero) const {
    if (!v.is_array() || v.size() != 3)
      fail(field, std::string("expected an array of 3 numbers, got ") +
                      (v.is_array() ? "an array of " + std::to_string(v.size()) : std::string(type_of(v))));
    Eigen::Vector3d out;
    for (int i = 0; i < 3; ++i) out[i] = number(v[i], field + "[" + std::to_string(i) + "]");
    if (non_zero && out.norm() < 1e-12) fail(field, "must be a non-zero vector");
    return out;
  }

  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

json read_json(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw FileError(path, "hand spec file not found");
  if (fs::is_directory(path, ec)) throw FileError(path, "is a directory, not a hand spec file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path, "cannot open hand spec file");
  try {
    return json::parse(in);
  } catch (const json::exception& e) {
    throw FileError(path, std::string("invalid JSON: ") + e.what());
  }
}

std::string field_at(const std::string& base, std::size_t i) { return base + "[" + std::to_string(i) + "]"; }

}  // namespace

Hand::Hand(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}

Hand Hand::load(const std::string& spec_path, const HandLoadOptions& options) {
  using hand_detail::KJoint;
  auto impl = std::make_shared<Impl>();
  Impl& h = *impl;
  h.spec_path = spec_path;
  const Spec spec(spec_path);
  const json doc = read_json(spec_path);
  spec.keys(doc, "", {"name", "urdf", "package_paths", "wrist_link", "approach", "dofs", "active_surfaces"});
  const fs::path spec_dir = fs::path(spec_path).parent_path();

  // ---------------------------------------------------------------- URDF
  const std::string urdf_name = spec.string(spec.require(doc, "", "urdf"), "urdf");
  fs::path urdf_path = fs::path(urdf_name);
  if (urdf_path.is_relative()) urdf_path = spec_dir / urdf_path;
  {
    std::error_code ec;
    if (!fs::is_regular_file(urdf_path, ec))
      spec.fail("urdf", "no such file '" + urdf_path.lexically_normal().string() + "'");
  }
  std::vector<std::string> package_paths = options.package_paths;
  if (doc.contains("package_paths")) {
    const json& pp = spec.array(doc["package_paths"], "package_paths", false);
    for (std::size_t i = 0; i < pp.size(); ++i) {
      fs::path p(spec.string(pp[i], field_at("package_paths", i)));
      if (p.is_relative()) p = spec_dir / p;
      package_paths.push_back(p.lexically_normal().string());
    }
  }
  const std::string urdf_file = urdf_path.filename().string();
  h.wrist = spec.string(spec.require(doc, "", "wrist_link"), "wrist_link");
  try {
    h.model = hand_detail::load_urdf(urdf_path.lexically_normal().string(), package_paths, h.wrist);
  } catch (const hand_detail::BadWrist& e) {
    spec.fail("wrist_link", std::string(e.what()) + " in " + urdf_file);
  }
  const hand_detail::KModel& km = h.model;

  h.name = km.robot_name;
  if (doc.contains("name")) h.name = spec.string(doc["name"], "name");

  // ---------------------------------------------------------------- wrist and approach
  h.wrist_index = km.link_index.at(h.wrist);  // 0: load_urdf() roots the hand at its wrist
  h.approach = spec.vec3(spec.require(doc, "", "approach"), "approach", true).normalized();

  // ---------------------------------------------------------------- DOFs
  const json& dofs = spec.array(spec.require(doc, "", "dofs"), "dofs");
  std::vector<hand_detail::Drive> direct(km.movable.size());  // joints named by a DOF
  std::vector<std::string> driven_by(km.movable.size());
  std::set<std::string> dof_names;
  for (std::size_t d = 0; d < dofs.size(); ++d) {
    const std::string f = field_at("dofs", d);
    const json& jd = dofs[d];
    spec.keys(jd, f, {"name", "joints", "lower", "upper", "step"});
    Dof dof;
    dof.name = spec.string(spec.require(jd, f, "name"), f + ".name");
    if (!dof_names.insert(dof.name).second) spec.fail(f + ".name", "duplicate DOF name '" + dof.name + "'");
    const json& joints = spec.array(spec.require(jd, f, "joints"), f + ".joints");
    int n_linear = 0;
    // Range of DOF values that keeps every driven joint (and its mimic followers) in its limits.
    double allowed_lo = -std::numeric_limits<double>::infinity();
    double allowed_hi = std::numeric_limits<double>::infinity();
    std::string lo_joint, hi_joint;  // the joints that set allowed_lo, allowed_hi
    for (std::size_t k = 0; k < joints.size(); ++k) {
      const std::string fj = field_at(f + ".joints", k);
      spec.keys(joints[k], fj, {"joint", "ratio", "offset"});
      DofJoint dj;
      dj.joint = spec.string(spec.require(joints[k], fj, "joint"), fj + ".joint");
      if (joints[k].contains("ratio")) dj.ratio = spec.number(joints[k]["ratio"], fj + ".ratio");
      if (joints[k].contains("offset")) dj.offset = spec.number(joints[k]["offset"], fj + ".offset");
      if (dj.ratio == 0.0) spec.fail(fj + ".ratio", "must be non-zero");
      auto it = km.joint_index.find(dj.joint);
      if (it == km.joint_index.end()) spec.fail(fj + ".joint", "no joint '" + dj.joint + "' in " + urdf_file);
      const KJoint& kj = km.joints[it->second];
      if (kj.type == KJoint::Fixed) spec.fail(fj + ".joint", "joint '" + dj.joint + "' is fixed");
      if (!kj.mimic_of.empty())
        spec.fail(fj + ".joint", "joint '" + dj.joint + "' is a <mimic> of '" + kj.mimic_of + "' in " + urdf_file +
                                     "; drive '" + kj.mimic_of + "' instead");
      if (!driven_by[kj.value_index].empty())
        spec.fail(fj + ".joint", "joint '" + dj.joint + "' is already driven by " + driven_by[kj.value_index]);
      driven_by[kj.value_index] = f + " ('" + dof.name + "')";
      direct[kj.value_index] = {static_cast<int>(d), dj.ratio, dj.offset};
      if (kj.type == KJoint::Prismatic) ++n_linear;

      // Limits of this joint and of every joint that mimics it (directly or through a chain),
      // as affine functions of the DOF value.
      std::vector<std::pair<int, hand_detail::Drive>> stack = {{it->second, {0, dj.ratio, dj.offset}}};
      while (!stack.empty()) {
        auto [ji, drv] = stack.back();
        stack.pop_back();
        const KJoint& j = km.joints[ji];
        if (j.limited) {
          double a = (j.lower - drv.offset) / drv.ratio, b = (j.upper - drv.offset) / drv.ratio;
          if (a > b) std::swap(a, b);
          a += 0.0, b += 0.0;  // no negative zeros (a limit of 0 through a ratio of -1)
          if (a > allowed_lo) allowed_lo = a, lo_joint = j.name;
          if (b < allowed_hi) allowed_hi = b, hi_joint = j.name;
        }
        for (std::size_t m = 0; m < km.joints.size(); ++m)
          if (km.joints[m].mimic == ji)
            stack.push_back({static_cast<int>(m),
                             {0, km.joints[m].multiplier * drv.ratio,
                              km.joints[m].multiplier * drv.offset + km.joints[m].offset}});
      }
      dof.joints.push_back(dj);
    }
    if (n_linear != 0 && n_linear != static_cast<int>(joints.size()))
      spec.fail(f + ".joints", "mixes prismatic and rotational joints (a DOF has one unit)");
    dof.linear = n_linear != 0;
    if (allowed_lo > allowed_hi + kLimitTolerance)
      spec.fail(f + ".joints", "the URDF limits of its joints (and their mimic joints) leave no common range");
    if (dof.linear && !(std::isfinite(allowed_lo) && std::isfinite(allowed_hi)))
      spec.fail(f, "prismatic joints without limits: give \"lower\" and \"upper\"");
    const bool has_lo = jd.contains("lower"), has_hi = jd.contains("upper");
    dof.lower = has_lo ? spec.number(jd["lower"], f + ".lower") : (std::isfinite(allowed_lo) ? allowed_lo : -kPi);
    dof.upper = has_hi ? spec.number(jd["upper"], f + ".upper") : (std::isfinite(allowed_hi) ? allowed_hi : kPi);
    const std::string unit = dof.linear ? " m" : " rad";
    if (dof.lower > dof.upper)
      spec.fail(f + ".lower", "lower limit " + num(dof.lower) + " is greater than upper limit " + num(dof.upper));
    if (dof.lower < allowed_lo - kLimitTolerance)
      spec.fail(f + ".lower", num(dof.lower) + unit + " drives joint '" + lo_joint +
                                  "' beyond its URDF limits (this DOF may range over [" + num(allowed_lo) + ", " +
                                  num(allowed_hi) + "]" + unit + ")");
    if (dof.upper > allowed_hi + kLimitTolerance)
      spec.fail(f + ".upper", num(dof.upper) + unit + " drives joint '" + hi_joint +
                                  "' beyond its URDF limits (this DOF may range over [" + num(allowed_lo) + ", " +
                                  num(allowed_hi) + "]" + unit + ")");
    if (jd.contains("step")) {
      dof.step = spec.number(jd["step"], f + ".step");
      if (!(dof.step > 0)) spec.fail(f + ".step", "must be positive, got " + num(dof.step));
    } else {
      dof.step = dof.linear ? std::max((dof.upper - dof.lower) / 8.0, 1e-3) : 0.25;
    }
    h.dofs.push_back(std::move(dof));
  }
  for (std::size_t v = 0; v < km.movable.size(); ++v) {
    const KJoint& j = km.joints[km.movable[v]];
    if (j.mimic_of.empty() && driven_by[v].empty())
      spec.fail("dofs", "joint '" + j.name + "' of " + urdf_file + " is driven by no DOF (name it in a DOF's \"joints\")");
  }
  // Every joint value as an affine function of one DOF, mimic chains composed.
  h.drives.resize(km.movable.size());
  for (std::size_t v = 0; v < km.movable.size(); ++v) {
    int ji = km.movable[v];
    double mult = 1.0, off = 0.0;  // q_v = mult * q_master + off
    while (km.joints[ji].mimic >= 0) {
      off += mult * km.joints[ji].offset;
      mult *= km.joints[ji].multiplier;
      ji = km.joints[ji].mimic;
    }
    const hand_detail::Drive& root = direct[km.joints[ji].value_index];
    h.drives[v] = {root.dof, mult * root.ratio, mult * root.offset + off};
  }

  // ---------------------------------------------------------------- active surfaces
  const json& surfaces = spec.array(spec.require(doc, "", "active_surfaces"), "active_surfaces");
  std::vector<std::set<int>> active(km.geometry.size());
  for (std::size_t s = 0; s < surfaces.size(); ++s) {
    const std::string f = field_at("active_surfaces", s);
    const json& js = surfaces[s];
    spec.keys(js, f, {"link", "normal_cone", "box", "faces"});
    const std::string link = spec.string(spec.require(js, f, "link"), f + ".link");
    auto it = km.link_index.find(link);
    if (it == km.link_index.end()) spec.fail(f + ".link", "no link '" + link + "' in " + urdf_file);
    const int g = km.links[it->second].geometry;
    if (g < 0) spec.fail(f + ".link", "link '" + link + "' has no geometry in " + urdf_file);
    const Mesh& mesh = km.geometry[g].mesh;
    const int nf = static_cast<int>(mesh.faces.rows());
    const bool cone = js.contains("normal_cone"), list = js.contains("faces");
    if (cone == list) spec.fail(f, "needs exactly one of \"normal_cone\" and \"faces\"");

    std::vector<int> selected;
    std::string how;
    if (cone) {
      const std::string fc = f + ".normal_cone";
      spec.keys(js["normal_cone"], fc, {"axis", "half_angle_deg"});
      const Eigen::Vector3d axis = spec.vec3(spec.require(js["normal_cone"], fc, "axis"), fc + ".axis", true).normalized();
      const double half = spec.number(spec.require(js["normal_cone"], fc, "half_angle_deg"), fc + ".half_angle_deg");
      if (!(half > 0 && half <= 180))
        spec.fail(fc + ".half_angle_deg", "must be in (0, 180] degrees, got " + num(half));
      const double cos_half = std::cos(half * kPi / 180.0);
      for (int k = 0; k < nf; ++k)
        if (mesh.face_normal(k).dot(axis) >= cos_half - 1e-9) selected.push_back(k);
      how = "normal cone";
    } else {
      const json& faces = spec.array(js["faces"], f + ".faces");
      for (std::size_t k = 0; k < faces.size(); ++k) {
        const std::string fk = field_at(f + ".faces", k);
        if (!faces[k].is_number_integer()) spec.fail(fk, std::string("expected an integer, got ") + type_of(faces[k]));
        const long long idx = faces[k].get<long long>();
        if (idx < 0 || idx >= nf)
          spec.fail(fk, "face " + std::to_string(idx) + " out of range (link '" + link + "' has " +
                            std::to_string(nf) + " faces)");
        selected.push_back(static_cast<int>(idx));
      }
      how = "face list";
    }
    if (js.contains("box")) {
      const std::string fb = f + ".box";
      spec.keys(js["box"], fb, {"min", "max"});
      const Eigen::Vector3d lo = spec.vec3(spec.require(js["box"], fb, "min"), fb + ".min", false);
      const Eigen::Vector3d hi = spec.vec3(spec.require(js["box"], fb, "max"), fb + ".max", false);
      if ((lo.array() > hi.array()).any()) spec.fail(fb, "min must not exceed max");
      std::vector<int> kept;
      for (int k : selected) {
        const Eigen::Vector3d c = (mesh.vertices.row(mesh.faces(k, 0)) + mesh.vertices.row(mesh.faces(k, 1)) +
                                   mesh.vertices.row(mesh.faces(k, 2))).transpose() / 3.0;
        if ((c.array() >= lo.array() - 1e-12).all() && (c.array() <= hi.array() + 1e-12).all()) kept.push_back(k);
      }
      selected.swap(kept);
      how += " and box";
    }
    if (selected.empty())
      spec.fail(f, "selects no face of link '" + link + "' (" + how + ", " + std::to_string(nf) +
                       " faces, link frame)");
    active[g].insert(selected.begin(), selected.end());
  }
  for (std::size_t g = 0; g < km.geometry.size(); ++g) {
    h.model.geometry[g].active_faces.assign(active[g].begin(), active[g].end());
    if (!active[g].empty()) {
      hand_detail::LinkSample s = hand_detail::per_link_sample(h.model.geometry[g].mesh, h.model.geometry[g].active_faces);
      s.link = static_cast<int>(g);
      h.per_link.push_back(s);
    }
  }
  return Hand(std::move(impl));
}

}  // namespace pairgrasp
