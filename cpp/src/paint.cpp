// Paint files and regions: per-face free/occluded masks.
#include <pairgrasp/error.hpp>
#include <pairgrasp/paint.hpp>

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace pairgrasp {
namespace {

using json = nlohmann::json;

constexpr const char* kFormat = "pairgrasp-paint";
constexpr int kVersion = 1;

std::string num_str(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

std::string vec_str(const Eigen::Vector3d& v) {
  std::ostringstream s;
  s << '[' << v.x() << ", " << v.y() << ", " << v.z() << ']';
  return s.str();
}

// ---------------------------------------------------------------- region validation (values)

void check_finite(const std::string& field, const Eigen::Vector3d& v) {
  if (!v.allFinite()) throw std::invalid_argument(field + ": must be finite, got " + vec_str(v));
}

void validate_region(const PaintRegion& r, const std::string& prefix) {
  switch (r.shape) {
    case PaintRegion::Shape::halfspace:
      check_finite(prefix + "point", r.point);
      check_finite(prefix + "normal", r.normal);
      if (r.normal.squaredNorm() == 0.0) throw std::invalid_argument(prefix + "normal: must be non-zero");
      return;
    case PaintRegion::Shape::box:
      check_finite(prefix + "min", r.min);
      check_finite(prefix + "max", r.max);
      for (int k = 0; k < 3; ++k)
        if (r.min[k] > r.max[k])
          throw std::invalid_argument(prefix + "min: must be <= max on every axis, got min " + vec_str(r.min) +
                                      ", max " + vec_str(r.max));
      return;
    case PaintRegion::Shape::sphere:
      check_finite(prefix + "center", r.center);
      if (!std::isfinite(r.radius) || !(r.radius > 0.0))
        throw std::invalid_argument(prefix + "radius: must be finite and > 0, got " + num_str(r.radius));
      return;
    case PaintRegion::Shape::cylinder:
      check_finite(prefix + "start", r.start);
      check_finite(prefix + "end", r.end);
      if (r.start == r.end) throw std::invalid_argument(prefix + "end: must differ from start");
      if (!std::isfinite(r.radius) || !(r.radius > 0.0))
        throw std::invalid_argument(prefix + "radius: must be finite and > 0, got " + num_str(r.radius));
      return;
  }
  throw std::invalid_argument(prefix + "shape: unknown shape " + std::to_string(static_cast<int>(r.shape)));
}

Points face_centroids(const Mesh& mesh) {
  const auto F = mesh.faces.rows();
  const auto V = mesh.vertices.rows();
  Points c(F, 3);
  for (Eigen::Index f = 0; f < F; ++f) {
    Eigen::Vector3d s = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) {
      const auto i = mesh.faces(f, k);
      if (i < 0 || i >= V)
        throw std::invalid_argument("mesh.faces: index " + std::to_string(i) + " of face " + std::to_string(f) +
                                    " is out of range (" + std::to_string(V) + " vertices)");
      s += mesh.vertices.row(i).transpose();
    }
    c.row(f) = (s / 3.0).transpose();
  }
  return c;
}

Mask apply_checked(const Points& centroids, const std::vector<PaintRegion>& regions, Mask mask) {
  for (const auto& r : regions)
    for (Eigen::Index f = 0; f < centroids.rows(); ++f)
      if (r.contains(centroids.row(f).transpose())) mask[f] = r.free;
  return mask;
}

// ---------------------------------------------------------------- JSON reading

class Reader {
 public:
  explicit Reader(std::string path) : path_(std::move(path)) {}

  [[noreturn]] void fail(const std::string& field, const std::string& message) const {
    throw FileError(path_, field + ": " + message);
  }

  static std::string type_name(const json& j) { return j.type_name(); }

  const json& require(const json& obj, const char* key, const std::string& field) const {
    auto it = obj.find(key);
    if (it == obj.end()) fail(field, "missing");
    return *it;
  }

  double number(const json& j, const std::string& field) const {
    if (!j.is_number()) fail(field, "expected a number, got " + type_name(j));
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(field, "must be finite");
    return v;
  }

  Eigen::Vector3d vec3(const json& j, const std::string& field) const {
    if (!j.is_array()) fail(field, "expected an array of 3 numbers, got " + type_name(j));
    if (j.size() != 3) fail(field, "expected 3 numbers, got " + std::to_string(j.size()));
    Eigen::Vector3d v;
    for (int k = 0; k < 3; ++k) v[k] = number(j[k], field + "[" + std::to_string(k) + "]");
    return v;
  }

  std::string string(const json& j, const std::string& field) const {
    if (!j.is_string()) fail(field, "expected a string, got " + type_name(j));
    return j.get<std::string>();
  }

  bool mark(const json& j, const std::string& field) const {
    const std::string s = string(j, field);
    if (s == "free") return true;
    if (s == "occluded") return false;
    fail(field, "expected \"free\" or \"occluded\", got \"" + s + "\"");
  }

  PaintRegion region(const json& j, const std::string& field) const {
    if (!j.is_object()) fail(field, "expected an object, got " + type_name(j));
    const std::string shape = string(require(j, "shape", field + ".shape"), field + ".shape");
    PaintRegion r;
    std::vector<const char*> keys;
    if (shape == "halfspace") {
      r.shape = PaintRegion::Shape::halfspace;
      r.point = vec3(require(j, "point", field + ".point"), field + ".point");
      r.normal = vec3(require(j, "normal", field + ".normal"), field + ".normal");
      if (r.normal.squaredNorm() == 0.0) fail(field + ".normal", "must be non-zero");
      keys = {"point", "normal"};
    } else if (shape == "box") {
      r.shape = PaintRegion::Shape::box;
      r.min = vec3(require(j, "min", field + ".min"), field + ".min");
      r.max = vec3(require(j, "max", field + ".max"), field + ".max");
      for (int k = 0; k < 3; ++k)
        if (r.min[k] > r.max[k])
          fail(field + ".min", "must be <= max on every axis, got min " + vec_str(r.min) + ", max " + vec_str(r.max));
      keys = {"min", "max"};
    } else if (shape == "sphere") {
      r.shape = PaintRegion::Shape::sphere;
      r.center = vec3(require(j, "center", field + ".center"), field + ".center");
      r.radius = number(require(j, "radius", field + ".radius"), field + ".radius");
      if (!(r.radius > 0.0)) fail(field + ".radius", "must be > 0, got " + num_str(r.radius));
      keys = {"center", "radius"};
    } else if (shape == "cylinder") {
      r.shape = PaintRegion::Shape::cylinder;
      r.start = vec3(require(j, "start", field + ".start"), field + ".start");
      r.end = vec3(require(j, "end", field + ".end"), field + ".end");
      if (r.start == r.end) fail(field + ".end", "must differ from start");
      r.radius = number(require(j, "radius", field + ".radius"), field + ".radius");
      if (!(r.radius > 0.0)) fail(field + ".radius", "must be > 0, got " + num_str(r.radius));
      keys = {"start", "end", "radius"};
    } else {
      fail(field + ".shape", "unknown shape \"" + shape + "\" (expected halfspace, box, sphere or cylinder)");
    }
    r.free = mark(require(j, "mark", field + ".mark"), field + ".mark");
    for (auto it = j.begin(); it != j.end(); ++it) {
      const std::string& k = it.key();
      bool known = k == "shape" || k == "mark" || k == "comment";
      for (const char* allowed : keys) known = known || k == allowed;
      if (!known) fail(field + "." + k, "unknown key for a " + shape + " region");
    }
    return r;
  }

  // Applies an index list; `seen` records which list set each face (0 none, 1 free, 2 occluded).
  void apply_list(const json& j, const std::string& field, bool value, Eigen::Index faces, Mask& mask,
                  std::vector<char>& seen) const {
    if (!j.is_array()) fail(field, "expected an array of face indices, got " + type_name(j));
    const char tag = value ? 1 : 2;
    for (std::size_t i = 0; i < j.size(); ++i) {
      const std::string f = field + "[" + std::to_string(i) + "]";
      const json& e = j[i];
      if (!e.is_number_integer()) fail(f, "expected an integer face index, got " + e.dump());
      const bool negative = e.is_number_unsigned() ? false : e.get<std::int64_t>() < 0;
      if (negative || e.get<std::uint64_t>() >= static_cast<std::uint64_t>(faces))
        fail(f, "face index " + e.dump() + " is out of range (the mesh has " + std::to_string(faces) + " faces)");
      const auto idx = static_cast<Eigen::Index>(e.get<std::uint64_t>());
      if (seen[idx] != 0 && seen[idx] != tag)
        fail(f, "face " + std::to_string(idx) + " is listed as both free and occluded");
      seen[idx] = tag;
      mask[idx] = value;
    }
  }

  Paint read(const Mesh& mesh) const {
    std::ifstream in(path_, std::ios::binary);
    if (!in) fail("file", "cannot open");
    json doc;
    try {
      doc = json::parse(in);
    } catch (const json::exception& e) {
      fail("file", std::string("not valid JSON: ") + e.what());
    }
    if (!doc.is_object()) fail("file", "expected a JSON object, got " + type_name(doc));

    const json& fmt = require(doc, "format", "format");
    if (!fmt.is_string() || fmt.get<std::string>() != kFormat)
      fail("format", std::string("expected \"") + kFormat + "\", got " + fmt.dump());
    const json& ver = require(doc, "version", "version");
    if (!ver.is_number_integer()) fail("version", "expected an integer, got " + ver.dump());
    if (ver.get<std::int64_t>() != kVersion)
      fail("version", "unsupported version " + ver.dump() + " (this reader knows " + std::to_string(kVersion) + ")");

    for (auto it = doc.begin(); it != doc.end(); ++it) {
      const std::string& k = it.key();
      if (k != "format" && k != "version" && k != "mesh" && k != "faces" && k != "default" && k != "free" &&
          k != "occluded" && k != "regions" && k != "comment")
        fail(k, "unknown key");
    }
    if (doc.contains("mesh")) string(doc["mesh"], "mesh");
    if (doc.contains("comment")) string(doc["comment"], "comment");

    const Eigen::Index F = mesh.faces.rows();
    const json& faces = require(doc, "faces", "faces");
    if (!faces.is_number_integer()) fail("faces", "expected an integer, got " + faces.dump());
    if (faces.get<std::int64_t>() != static_cast<std::int64_t>(F))
      fail("faces", "the paint is for a mesh of " + faces.dump() + " faces, but " +
                        (mesh.source.empty() ? std::string("the mesh") : mesh.source) + " has " +
                        std::to_string(F));

    const bool def = doc.contains("default") ? mark(doc["default"], "default") : true;
    Mask mask = Mask::Constant(F, def);
    std::vector<char> seen(static_cast<std::size_t>(F), 0);
    if (doc.contains("free")) apply_list(doc["free"], "free", true, F, mask, seen);
    if (doc.contains("occluded")) apply_list(doc["occluded"], "occluded", false, F, mask, seen);

    Paint out;
    if (doc.contains("regions")) {
      const json& regs = doc["regions"];
      if (!regs.is_array()) fail("regions", "expected an array of regions, got " + type_name(regs));
      out.regions.reserve(regs.size());
      for (std::size_t i = 0; i < regs.size(); ++i) out.regions.push_back(region(regs[i], "regions[" + std::to_string(i) + "]"));
    }
    out.faces = std::move(mask);
    return out;
  }

 private:
  std::string path_;
};

std::string base_name(const std::string& p) {
  const auto slash = p.find_last_of("/\\");
  return slash == std::string::npos ? p : p.substr(slash + 1);
}

}  // namespace

// ---------------------------------------------------------------- PaintRegion

PaintRegion PaintRegion::halfspace(const Eigen::Vector3d& point, const Eigen::Vector3d& normal, bool free) {
  PaintRegion r;
  r.shape = Shape::halfspace;
  r.point = point;
  r.normal = normal;
  r.free = free;
  r.validate();
  return r;
}

PaintRegion PaintRegion::box(const Eigen::Vector3d& min, const Eigen::Vector3d& max, bool free) {
  PaintRegion r;
  r.shape = Shape::box;
  r.min = min;
  r.max = max;
  r.free = free;
  r.validate();
  return r;
}

PaintRegion PaintRegion::sphere(const Eigen::Vector3d& center, double radius, bool free) {
  PaintRegion r;
  r.shape = Shape::sphere;
  r.center = center;
  r.radius = radius;
  r.free = free;
  r.validate();
  return r;
}

PaintRegion PaintRegion::cylinder(const Eigen::Vector3d& start, const Eigen::Vector3d& end, double radius,
                                  bool free) {
  PaintRegion r;
  r.shape = Shape::cylinder;
  r.start = start;
  r.end = end;
  r.radius = radius;
  r.free = free;
  r.validate();
  return r;
}

void PaintRegion::validate() const { validate_region(*this, ""); }

bool PaintRegion::contains(const Eigen::Vector3d& p) const {
  switch (shape) {
    case Shape::halfspace:
      return (p - point).dot(normal) >= 0.0;
    case Shape::box:
      return (p.array() >= min.array()).all() && (p.array() <= max.array()).all();
    case Shape::sphere:
      return (p - center).squaredNorm() <= radius * radius;
    case Shape::cylinder: {
      const Eigen::Vector3d axis = end - start;
      const double len2 = axis.squaredNorm();
      const double t = (p - start).dot(axis);  // projection, in units of len2
      if (t < 0.0 || t > len2) return false;
      return (p - start - axis * (t / len2)).squaredNorm() <= radius * radius;
    }
  }
  return false;
}

const char* to_string(PaintRegion::Shape shape) {
  switch (shape) {
    case PaintRegion::Shape::halfspace: return "halfspace";
    case PaintRegion::Shape::box: return "box";
    case PaintRegion::Shape::sphere: return "sphere";
    case PaintRegion::Shape::cylinder: return "cylinder";
  }
  return "unknown";
}

// ---------------------------------------------------------------- masks

Mask apply_regions(const Mesh& mesh, const std::vector<PaintRegion>& regions, const Mask& start) {
  detail::check_size("start", static_cast<long>(mesh.faces.rows()), static_cast<long>(start.size()));
  for (std::size_t i = 0; i < regions.size(); ++i) validate_region(regions[i], "regions[" + std::to_string(i) + "].");
  return apply_checked(face_centroids(mesh), regions, start);
}

Mask apply_regions(const Mesh& mesh, const std::vector<PaintRegion>& regions) {
  return apply_regions(mesh, regions, Mask::Constant(mesh.faces.rows(), true));
}

Paint read_paint(const std::string& path, const Mesh& mesh) { return Reader(path).read(mesh); }

Mask load_paint(const std::string& path, const Mesh& mesh) {
  const Paint paint = Reader(path).read(mesh);
  const Mask mask = apply_checked(face_centroids(mesh), paint.regions, paint.faces);
  if (!mask.any()) throw std::invalid_argument(path + ": paint leaves no free face");
  return mask;
}

void save_paint(const std::string& path, const Mesh& mesh, const Mask& free_mask) {
  const Eigen::Index F = mesh.faces.rows();
  detail::check_size("free_mask", static_cast<long>(F), static_cast<long>(free_mask.size()));
  const Eigen::Index n_free = free_mask.count();
  if (n_free == 0) throw std::invalid_argument("free_mask: paint leaves no free face");
  const bool default_free = n_free * 2 >= F;  // the larger side is the default

  std::ostringstream out;
  out << "{\n  \"format\": \"" << kFormat << "\",\n  \"version\": " << kVersion << ",\n";
  if (!mesh.source.empty()) out << "  \"mesh\": " << json(base_name(mesh.source)).dump() << ",\n";
  out << "  \"faces\": " << F << ",\n  \"default\": \"" << (default_free ? "free" : "occluded") << "\",\n";
  out << "  \"" << (default_free ? "occluded" : "free") << "\": [";
  int on_line = 0;
  bool first = true;
  for (Eigen::Index f = 0; f < F; ++f) {
    if (free_mask[f] == default_free) continue;
    if (!first) out << (on_line == 0 ? ",\n    " : ", ");
    else out << "\n    ";
    out << f;
    first = false;
    on_line = (on_line + 1) % 16;
  }
  out << (first ? "]\n}\n" : "\n  ]\n}\n");

  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) throw FileError(path, "file: cannot open for writing");
  file << out.str();
  file.close();
  if (!file) throw FileError(path, "file: write failed");
}

}  // namespace pairgrasp
