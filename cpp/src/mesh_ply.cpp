// A PLY reader (ASCII, binary little- and big-endian) and polygon triangulation.
//
// PLY is read here rather than through assimp: assimp 5.2 hangs on a PLY file whose header is
// cut short, aborts the process (an internal assertion) on one whose face list is cut short, and
// silently returns the faces read so far on others. This reader checks every count against the
// file and says which element or line is at fault.
#include <pairgrasp/error.hpp>

#include "mesh_internal.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace pairgrasp::detail {

namespace {

enum class PlyType { i8, u8, i16, u16, i32, u32, f32, f64 };

bool parse_type(const std::string& s, PlyType& t) {
  static const std::pair<const char*, PlyType> names[] = {
      {"char", PlyType::i8},   {"int8", PlyType::i8},    {"uchar", PlyType::u8},   {"uint8", PlyType::u8},
      {"short", PlyType::i16}, {"int16", PlyType::i16},  {"ushort", PlyType::u16}, {"uint16", PlyType::u16},
      {"int", PlyType::i32},   {"int32", PlyType::i32},  {"uint", PlyType::u32},   {"uint32", PlyType::u32},
      {"float", PlyType::f32}, {"float32", PlyType::f32}, {"double", PlyType::f64}, {"float64", PlyType::f64}};
  for (const auto& [name, type] : names)
    if (s == name) {
      t = type;
      return true;
    }
  return false;
}

std::size_t type_size(PlyType t) {
  switch (t) {
    case PlyType::i8:
    case PlyType::u8: return 1;
    case PlyType::i16:
    case PlyType::u16: return 2;
    case PlyType::i32:
    case PlyType::u32:
    case PlyType::f32: return 4;
    case PlyType::f64: return 8;
  }
  return 0;
}

bool is_integer(PlyType t) { return t != PlyType::f32 && t != PlyType::f64; }

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::f32;  // item type for lists
  bool is_list = false;
  PlyType count_type = PlyType::u8;
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
  int header_line = 0;
};

enum class PlyFormat { ascii, binary_le, binary_be };

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    std::size_t j = i;
    while (j < line.size() && !std::isspace(static_cast<unsigned char>(line[j]))) ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

// Reads the values of the body, ASCII or binary, with positions for error messages.
class PlyBody {
 public:
  PlyBody(const std::string& path, const std::string& data, std::size_t start, PlyFormat format, int first_line)
      : path_(path), data_(data), pos_(start), format_(format), line_(first_line) {}

  std::size_t remaining() const { return data_.size() - pos_; }

  double read_number(PlyType t, const std::string& what) {
    if (format_ == PlyFormat::ascii) return read_ascii(t, what);
    return read_binary(t, what);
  }

  std::string where() const {
    if (format_ == PlyFormat::ascii) return "line " + std::to_string(line_);
    return "byte " + std::to_string(pos_);
  }

 private:
  [[noreturn]] void fail(const std::string& message) const { throw FileError(path_, message); }

  double read_ascii(PlyType t, const std::string& what) {
    while (pos_ < data_.size() && std::isspace(static_cast<unsigned char>(data_[pos_]))) {
      if (data_[pos_] == '\n') ++line_;
      ++pos_;
    }
    if (pos_ >= data_.size()) fail("ends early, at line " + std::to_string(line_) + ", while reading " + what);
    std::size_t end = pos_;
    while (end < data_.size() && !std::isspace(static_cast<unsigned char>(data_[end]))) ++end;
    const char* first = data_.data() + pos_;
    const char* last = data_.data() + end;
    if (last - first > 1 && *first == '+') ++first;  // from_chars takes no leading '+'
    double value = 0.0;
    bool ok = false;
    if (is_integer(t)) {
      long long v = 0;
      const auto r = std::from_chars(first, last, v);
      ok = r.ec == std::errc() && r.ptr == last;
      value = static_cast<double>(v);
    } else {
      const auto r = std::from_chars(first, last, value);
      ok = r.ec == std::errc() && r.ptr == last;
    }
    if (!ok)
      fail("line " + std::to_string(line_) + ": '" + std::string(first, std::min<std::size_t>(last - first, 40)) +
           "' is not " + (is_integer(t) ? "an integer" : "a number") + " (" + what + ")");
    pos_ = end;
    return value;
  }

  double read_binary(PlyType t, const std::string& what) {
    const std::size_t n = type_size(t);
    if (pos_ + n > data_.size()) fail("ends early, at byte " + std::to_string(pos_) + ", while reading " + what);
    unsigned char b[8];
    std::memcpy(b, data_.data() + pos_, n);
    pos_ += n;
    const bool swap = (format_ == PlyFormat::binary_be) != big_endian_host();
    if (swap) std::reverse(b, b + n);
    switch (t) {
      case PlyType::i8: return static_cast<double>(static_cast<std::int8_t>(b[0]));
      case PlyType::u8: return static_cast<double>(b[0]);
      case PlyType::i16: return from_bytes<std::int16_t>(b);
      case PlyType::u16: return from_bytes<std::uint16_t>(b);
      case PlyType::i32: return from_bytes<std::int32_t>(b);
      case PlyType::u32: return from_bytes<std::uint32_t>(b);
      case PlyType::f32: return from_bytes<float>(b);
      case PlyType::f64: return from_bytes<double>(b);
    }
    return 0.0;
  }

  template <class T>
  static double from_bytes(const unsigned char* b) {
    T v;
    std::memcpy(&v, b, sizeof v);
    return static_cast<double>(v);
  }

  static bool big_endian_host() {
    const std::uint16_t one = 1;
    unsigned char c;
    std::memcpy(&c, &one, 1);
    return c == 0;
  }

  const std::string& path_;
  const std::string& data_;
  std::size_t pos_;
  PlyFormat format_;
  int line_;
};

}  // namespace

bool has_ply_magic(const std::string& head) {
  // Anything that starts like a PLY file: assimp's PLY importer claims such files too (and hangs
  // on some), so the reader below takes them all and refuses a malformed first line itself.
  return head.size() >= 3 && std::tolower(static_cast<unsigned char>(head[0])) == 'p' &&
         std::tolower(static_cast<unsigned char>(head[1])) == 'l' &&
         std::tolower(static_cast<unsigned char>(head[2])) == 'y';
}

void read_ply(const std::string& path, const std::string& data, Points& vertices, Triangles& faces) {
  auto fail = [&path](const std::string& message) { throw FileError(path, message); };

  // ---- header
  PlyFormat format = PlyFormat::ascii;
  bool have_format = false;
  std::vector<PlyElement> elements;
  std::size_t pos = 0;
  int line_no = 0;
  bool ended = false;
  while (pos < data.size()) {
    std::size_t eol = data.find('\n', pos);
    if (eol == std::string::npos) eol = data.size();
    std::string line = data.substr(pos, eol - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = std::min(eol + 1, data.size());
    ++line_no;
    const std::vector<std::string> tok = split(line);
    const std::string at = "header line " + std::to_string(line_no) + ": ";
    if (line_no == 1) {
      if (tok.size() != 1 || tok[0] != "ply") fail("not a PLY file (the first line is not 'ply')");
      continue;
    }
    if (tok.empty()) continue;
    const std::string& key = tok[0];
    if (key == "comment" || key == "obj_info") continue;
    if (key == "end_header") {
      ended = true;
      break;
    }
    if (key == "format") {
      if (tok.size() != 3) fail(at + "expected 'format <ascii|binary_little_endian|binary_big_endian> 1.0'");
      if (tok[1] == "ascii") format = PlyFormat::ascii;
      else if (tok[1] == "binary_little_endian") format = PlyFormat::binary_le;
      else if (tok[1] == "binary_big_endian") format = PlyFormat::binary_be;
      else fail(at + "unknown format '" + tok[1] + "'");
      if (tok[2].rfind("1", 0) != 0) fail(at + "unsupported version '" + tok[2] + "'");
      have_format = true;
    } else if (key == "element") {
      if (tok.size() != 3) fail(at + "expected 'element <name> <count>'");
      PlyElement e;
      e.name = tok[1];
      e.header_line = line_no;
      const auto r = std::from_chars(tok[2].data(), tok[2].data() + tok[2].size(), e.count);
      if (r.ec != std::errc() || r.ptr != tok[2].data() + tok[2].size())
        fail(at + "element count '" + tok[2] + "' is not a non-negative integer");
      elements.push_back(e);
    } else if (key == "property") {
      if (elements.empty()) fail(at + "property before any element");
      PlyProperty p;
      if (tok.size() == 5 && tok[1] == "list") {
        p.is_list = true;
        if (!parse_type(tok[2], p.count_type) || !is_integer(p.count_type))
          fail(at + "list count type '" + tok[2] + "' is not an integer type");
        if (!parse_type(tok[3], p.type)) fail(at + "unknown type '" + tok[3] + "'");
        p.name = tok[4];
      } else if (tok.size() == 3 && tok[1] != "list") {
        if (!parse_type(tok[1], p.type)) fail(at + "unknown type '" + tok[1] + "'");
        p.name = tok[2];
      } else {
        fail(at + "expected 'property <type> <name>' or 'property list <count type> <item type> <name>'");
      }
      elements.back().properties.push_back(p);
    } else {
      fail(at + "unknown keyword '" + key + "'");
    }
  }
  if (!ended) fail("PLY header has no 'end_header' line");
  if (!have_format) fail("PLY header has no 'format' line");

  // ---- which properties matter
  const PlyElement* vertex_el = nullptr;
  const PlyElement* face_el = nullptr;
  for (const PlyElement& e : elements) {
    if (e.name == "vertex" && !vertex_el) vertex_el = &e;
    if (e.name == "face" && !face_el) face_el = &e;
  }
  if (!vertex_el) fail("PLY header declares no 'vertex' element");
  int xyz[3] = {-1, -1, -1};
  for (std::size_t i = 0; i < vertex_el->properties.size(); ++i) {
    const PlyProperty& p = vertex_el->properties[i];
    for (int a = 0; a < 3; ++a)
      if (p.name == std::string(1, static_cast<char>('x' + a)) && !p.is_list) xyz[a] = static_cast<int>(i);
  }
  for (int a = 0; a < 3; ++a)
    if (xyz[a] < 0) fail(std::string("element 'vertex' has no scalar property '") + static_cast<char>('x' + a) + "'");
  int indices_prop = -1;
  if (face_el) {
    for (std::size_t i = 0; i < face_el->properties.size(); ++i) {
      const PlyProperty& p = face_el->properties[i];
      if (p.is_list && (p.name == "vertex_indices" || p.name == "vertex_index")) indices_prop = static_cast<int>(i);
    }
    if (indices_prop < 0) fail("element 'face' has no list property 'vertex_indices'");
    if (!is_integer(face_el->properties[indices_prop].type)) fail("face 'vertex_indices' must be of an integer type");
  }

  // ---- body
  PlyBody body(path, data, pos, format, line_no + 1);
  const std::uint64_t max_vertices = static_cast<std::uint64_t>(std::numeric_limits<std::int32_t>::max());
  if (vertex_el->count > max_vertices) fail("too many vertices (" + std::to_string(vertex_el->count) + ")");
  std::vector<std::array<std::int64_t, 3>> tris;
  std::vector<std::int64_t> poly;
  for (const PlyElement& e : elements) {
    // Every instance takes at least one byte per value: refuse counts the file cannot hold
    // before allocating anything for them.
    std::uint64_t min_bytes = 0;
    for (const PlyProperty& p : e.properties)
      min_bytes += format == PlyFormat::ascii ? 2 : type_size(p.is_list ? p.count_type : p.type);
    if (min_bytes > 0 && e.count > body.remaining() / min_bytes + 1)
      fail("element '" + e.name + "' (header line " + std::to_string(e.header_line) + ") declares " +
           std::to_string(e.count) + " items, more than the file holds");
    if (&e == vertex_el) vertices.resize(static_cast<Eigen::Index>(e.count), 3);
    if (e.properties.empty()) continue;  // nothing stored per item
    for (std::uint64_t k = 0; k < e.count; ++k) {
      for (std::size_t pi = 0; pi < e.properties.size(); ++pi) {
        const PlyProperty& p = e.properties[pi];
        if (!p.is_list) {
          const double v = body.read_number(p.type, e.name + " " + std::to_string(k) + " " + p.name);
          if (&e == vertex_el)
            for (int a = 0; a < 3; ++a)
              if (xyz[a] == static_cast<int>(pi)) vertices(static_cast<Eigen::Index>(k), a) = v;
          continue;
        }
        const std::string what = e.name + " " + std::to_string(k) + " " + p.name;
        const double n = body.read_number(p.count_type, what + " count");
        if (n < 0 || n > static_cast<double>(body.remaining()))
          fail(body.where() + ": " + what + " has an impossible length " + std::to_string(static_cast<long long>(n)));
        const bool indices = &e == face_el && static_cast<int>(pi) == indices_prop;
        if (indices) poly.clear();
        for (long long j = 0; j < static_cast<long long>(n); ++j) {
          const double v = body.read_number(p.type, what);
          if (indices) poly.push_back(static_cast<std::int64_t>(v));
        }
        if (!indices) continue;
        if (poly.size() < 3)
          fail("face " + std::to_string(k) + " has " + std::to_string(poly.size()) + " vertex indices; a face needs 3 or more");
        for (std::int64_t idx : poly)
          if (idx < 0 || idx >= vertices.rows())
            fail("face " + std::to_string(k) + " has vertex index " + std::to_string(idx) + " out of range [0, " +
                 std::to_string(vertices.rows()) + ")");
        triangulate_polygon(vertices, poly, tris);
      }
    }
  }
  faces.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (std::size_t i = 0; i < tris.size(); ++i)
    for (int k = 0; k < 3; ++k) faces(static_cast<Eigen::Index>(i), k) = static_cast<std::int32_t>(tris[i][k]);
}

// Ear clipping in the polygon's plane (Newell normal), keeping the polygon's winding. Falls back
// to a fan when no ear is found (self-intersecting or degenerate polygons); degenerate
// triangles are removed later by the clean-up.
void triangulate_polygon(const Points& v, const std::vector<std::int64_t>& poly,
                         std::vector<std::array<std::int64_t, 3>>& out) {
  const std::size_t n = poly.size();
  if (n < 3) return;
  if (n == 3) {
    out.push_back({poly[0], poly[1], poly[2]});
    return;
  }
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d a = v.row(poly[i]), b = v.row(poly[(i + 1) % n]);
    normal += Eigen::Vector3d((a.y() - b.y()) * (a.z() + b.z()), (a.z() - b.z()) * (a.x() + b.x()),
                              (a.x() - b.x()) * (a.y() + b.y()));
  }
  auto fan = [&](const std::vector<std::size_t>& ring) {
    for (std::size_t i = 1; i + 1 < ring.size(); ++i) out.push_back({poly[ring[0]], poly[ring[i]], poly[ring[i + 1]]});
  };
  std::vector<std::size_t> ring(n);
  for (std::size_t i = 0; i < n; ++i) ring[i] = i;
  if (!(normal.norm() > 0.0)) {
    fan(ring);
    return;
  }
  // 2-D coordinates in the plane, counter-clockwise about the normal.
  Eigen::Vector3d u = normal.unitOrthogonal(), w = normal.normalized().cross(u);
  std::vector<Eigen::Vector2d> p(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d q = v.row(poly[i]);
    p[i] = Eigen::Vector2d(q.dot(u), q.dot(w));
  }
  auto cross = [&](std::size_t a, std::size_t b, std::size_t c) {
    return (p[b] - p[a]).x() * (p[c] - p[a]).y() - (p[b] - p[a]).y() * (p[c] - p[a]).x();
  };
  while (ring.size() > 3) {
    const std::size_t m = ring.size();
    bool clipped = false;
    for (std::size_t i = 0; i < m && !clipped; ++i) {
      const std::size_t a = ring[(i + m - 1) % m], b = ring[i], c = ring[(i + 1) % m];
      if (cross(a, b, c) <= 0.0) continue;  // reflex or flat corner
      bool empty = true;
      for (std::size_t j = 0; j < m && empty; ++j) {
        const std::size_t q = ring[j];
        if (q == a || q == b || q == c) continue;
        if (cross(a, b, q) >= 0.0 && cross(b, c, q) >= 0.0 && cross(c, a, q) >= 0.0) empty = false;
      }
      if (!empty) continue;
      out.push_back({poly[a], poly[b], poly[c]});
      ring.erase(ring.begin() + static_cast<std::ptrdiff_t>(i));
      clipped = true;
    }
    if (!clipped) {
      fan(ring);
      return;
    }
  }
  out.push_back({poly[ring[0]], poly[ring[1]], poly[ring[2]]});
}

}  // namespace pairgrasp::detail
