// load_mesh(): reading mesh files through assimp, then the clean-up of mesh.cpp.
#include <pairgrasp/error.hpp>
#include <pairgrasp/mesh.hpp>

#include "mesh_internal.hpp"

#include <assimp/Importer.hpp>
#include <assimp/commonMetaData.h>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <locale>
#include <regex>
#include <sstream>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

namespace pairgrasp {

namespace {

namespace fs = std::filesystem;

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

// Position of the first tag `<name` (followed by a space, '>' or '/') in text[from, to),
// skipping comments; npos when there is none.
std::size_t find_tag(const std::string& text, const std::string& name, std::size_t from, std::size_t to) {
  const std::string open = "<" + name;
  std::size_t i = from;
  while (i < to) {
    i = text.find('<', i);
    if (i == std::string::npos || i >= to) return std::string::npos;
    if (text.compare(i, 4, "<!--") == 0) {
      const std::size_t end = text.find("-->", i + 4);
      if (end == std::string::npos) return std::string::npos;
      i = end + 3;
      continue;
    }
    if (text.compare(i, open.size(), open) == 0 && i + open.size() < text.size()) {
      const char next = text[i + open.size()];
      if (std::isspace(static_cast<unsigned char>(next)) || next == '>' || next == '/') return i;
    }
    ++i;
  }
  return std::string::npos;
}

// The length unit of a COLLADA file in metres: the `meter` attribute of the top-level
// <asset><unit>, 1 when absent (the COLLADA default). Reads only as far as the end of <asset>.
double collada_unit(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path, "cannot be opened for reading");
  std::string text;
  std::size_t asset_end = std::string::npos;
  char buffer[65536];
  while (asset_end == std::string::npos && in) {
    in.read(buffer, sizeof buffer);
    const std::size_t before = text.size();
    text.append(buffer, static_cast<std::size_t>(in.gcount()));
    asset_end = text.find("</asset", before >= 8 ? before - 8 : 0);
  }
  const std::size_t asset = find_tag(text, "asset", 0, text.size());
  if (asset == std::string::npos) return 1.0;
  if (asset_end == std::string::npos || asset_end < asset) asset_end = text.size();
  const std::size_t unit = find_tag(text, "unit", asset, asset_end);
  if (unit == std::string::npos) return 1.0;
  const std::size_t unit_end = text.find('>', unit);
  if (unit_end == std::string::npos) throw FileError(path, "<asset><unit>: unterminated tag");
  const std::string tag = text.substr(unit, unit_end - unit);
  static const std::regex meter_attr(R"re(\smeter\s*=\s*(?:"([^"]*)"|'([^']*)'))re");
  std::smatch match;
  if (!std::regex_search(tag, match, meter_attr)) return 1.0;  // meter defaults to 1.0
  const std::string value = match[1].matched ? match[1].str() : match[2].str();
  std::istringstream parse(value);
  parse.imbue(std::locale::classic());
  double meter = 0.0;
  parse >> meter;
  const bool complete = !parse.fail() && (parse >> std::ws).eof();
  if (!complete || !std::isfinite(meter) || meter <= 0.0)
    throw FileError(path, "<asset><unit meter=\"" + value + "\">: expected a positive number of metres");
  return meter;
}

bool is_collada(const aiScene* scene, const std::string& path) {
  aiString format;
  if (scene->mMetaData && scene->mMetaData->Get(AI_METADATA_SOURCE_FORMAT, format))
    return lower(format.C_Str()).find("collada") != std::string::npos;
  return lower(fs::path(path).extension().string()) == ".dae";
}

Eigen::Matrix4d to_eigen(const aiMatrix4x4& m) {
  Eigen::Matrix4d e;
  for (unsigned r = 0; r < 4; ++r)
    for (unsigned c = 0; c < 4; ++c) e(r, c) = static_cast<double>(m[r][c]);
  return e;
}

struct Instance {
  const aiMesh* mesh;
  Eigen::Matrix4d transform;
};

}  // namespace

Mesh load_mesh(const std::string& path, const MeshLoadOptions& options) {
  detail::check_mesh_options(options);

  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (!fs::exists(status)) throw FileError(path, "file not found");
  if (fs::is_directory(status)) throw FileError(path, "is a directory, not a mesh file");
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) throw FileError(path, "cannot be opened for reading");
    if (probe.peek() == std::ifstream::traits_type::eof()) throw FileError(path, "empty file");
  }

  Assimp::Importer importer;
  // Keep COLLADA's authored axes (assimp otherwise turns Z-up files to Y-up).
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate);
  if (!scene) {
    // assimp sometimes quotes the rest of the file: keep the message to its first line and 200 chars.
    std::string why = importer.GetErrorString();
    why = why.substr(0, why.find_first_of("\r\n"));
    if (why.size() > 200) why = why.substr(0, 200) + "...";
    throw FileError(path, "cannot be read as a mesh: " + why);
  }
  if (!scene->mRootNode) throw FileError(path, "cannot be read as a mesh: the scene has no root node");

  // COLLADA: assimp's root node is the <visual_scene>, which has no transform of its own in the
  // format; the loader puts there its unit scale (and, without the property above, its up-axis
  // rotation), which assimp versions do differently. Drop it and apply the file's unit once.
  const bool collada = is_collada(scene, path);
  const double unit = collada ? collada_unit(path) : 1.0;

  std::vector<Instance> instances;
  std::vector<std::pair<const aiNode*, Eigen::Matrix4d>> stack;
  stack.emplace_back(scene->mRootNode, collada ? Eigen::Matrix4d::Identity().eval()
                                               : to_eigen(scene->mRootNode->mTransformation));
  Eigen::Index n_vertices = 0, n_faces = 0;
  while (!stack.empty()) {
    const auto [node, transform] = stack.back();
    stack.pop_back();
    for (unsigned i = 0; i < node->mNumMeshes; ++i) {
      const unsigned id = node->mMeshes[i];
      if (id >= scene->mNumMeshes)
        throw FileError(path, "node '" + std::string(node->mName.C_Str()) + "' refers to missing mesh " + std::to_string(id));
      const aiMesh* mesh = scene->mMeshes[id];
      instances.push_back({mesh, transform});
      n_vertices += mesh->mNumVertices;
      for (unsigned f = 0; f < mesh->mNumFaces; ++f) n_faces += mesh->mFaces[f].mNumIndices == 3 ? 1 : 0;
    }
    // Children pushed in reverse so that they are visited in file order.
    for (unsigned c = node->mNumChildren; c-- > 0;)
      stack.emplace_back(node->mChildren[c], transform * to_eigen(node->mChildren[c]->mTransformation));
  }

  if (n_vertices > std::numeric_limits<std::int32_t>::max())
    throw FileError(path, "too many vertices (" + std::to_string(n_vertices) + ") for 32-bit indices");

  Points vertices(n_vertices, 3);
  Triangles faces(n_faces, 3);
  Eigen::Index v0 = 0, f_out = 0;
  for (const Instance& inst : instances) {
    const aiMesh* mesh = inst.mesh;
    const Eigen::Matrix3d linear = inst.transform.topLeftCorner<3, 3>();
    const Eigen::Vector3d shift = inst.transform.topRightCorner<3, 1>();
    const bool mirrored = linear.determinant() < 0.0;  // keep mirrored copies outward
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& p = mesh->mVertices[v];
      vertices.row(v0 + v) = (linear * Eigen::Vector3d(p.x, p.y, p.z) + shift).transpose();
    }
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines
      for (int k = 0; k < 3; ++k) {
        const unsigned idx = face.mIndices[k];
        if (idx >= mesh->mNumVertices)
          throw FileError(path, "mesh '" + std::string(mesh->mName.C_Str()) + "' face " + std::to_string(f) +
                                    " has index " + std::to_string(idx) + " out of range [0, " +
                                    std::to_string(mesh->mNumVertices) + ")");
        faces(f_out, mirrored ? 2 - k : k) = static_cast<std::int32_t>(v0 + idx);
      }
      ++f_out;
    }
    v0 += mesh->mNumVertices;
  }

  const detail::MeshFail fail = [&path](const std::string&, const std::string& message) {
    throw FileError(path, message);
  };
  return detail::build_mesh(std::move(vertices), std::move(faces), path, options, fail, unit);
}

}  // namespace pairgrasp
