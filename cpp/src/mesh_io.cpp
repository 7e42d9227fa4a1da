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
#include <filesystem>
#include <fstream>
#include <limits>
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

std::string read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path, "cannot be opened for reading");
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw FileError(path, "read error");
  return s.str();
}

std::string read_head(const std::string& path, std::size_t n) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path, "cannot be opened for reading");
  std::string head(n, '\0');
  in.read(head.data(), static_cast<std::streamsize>(n));
  head.resize(static_cast<std::size_t>(in.gcount()));
  return head;
}

bool is_collada(const aiScene* scene) {
  aiString format;
  return scene->mMetaData && scene->mMetaData->Get(AI_METADATA_SOURCE_FORMAT, format) &&
         lower(format.C_Str()).find("collada") != std::string::npos;
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
  const std::string head = read_head(path, 4096);
  if (head.empty()) throw FileError(path, "empty file");
  const detail::MeshFail fail = [&path](const std::string&, const std::string& message) {
    throw FileError(path, message);
  };

  // PLY: our own reader (see mesh_ply.cpp for why not assimp's), for every .ply file and
  // anything else that starts like one (but a binary STL, whose 80-byte header is free text), so
  // that no PLY-like file reaches assimp's PLY importer.
  const std::string ext = lower(fs::path(path).extension().string());
  if (ext == ".ply" || (ext != ".stl" && detail::has_ply_magic(head))) {
    Points vertices;
    Triangles faces;
    detail::read_ply(path, read_all(path), vertices, faces);
    return detail::build_mesh(std::move(vertices), std::move(faces), path, options, fail);
  }

  // COLLADA: read the unit, and check what assimp cannot be trusted with, before assimp parses.
  bool collada = ext == ".dae" || detail::looks_like_collada(head);
  double unit = 1.0;
  if (collada) unit = detail::check_collada(path, read_all(path));

  Assimp::Importer importer;
  // Keep COLLADA's authored axes (assimp otherwise turns Z-up files to Y-up).
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
  const aiScene* scene = importer.ReadFile(path, 0);
  auto assimp_error = [&] {
    // assimp sometimes quotes the rest of the file: keep the message to its first line and 200 chars.
    std::string why = importer.GetErrorString();
    why = why.substr(0, why.find_first_of("\r\n"));
    if (why.size() > 200) why = why.substr(0, 200) + "...";
    return FileError(path, "cannot be read as a mesh: " + why);
  };
  if (!scene) throw assimp_error();
  if (!scene->mRootNode) throw FileError(path, "cannot be read as a mesh: the scene has no root node");
  // Triangulate polygons. assimp's step asserts (aborting the process) when a mesh's primitive
  // types disagree with its faces, as some importers leave them for malformed files: recompute
  // them from the faces first. Face order and vertices are left as they are.
  for (unsigned i = 0; i < scene->mNumMeshes; ++i) {
    aiMesh* mesh = scene->mMeshes[i];
    unsigned types = 0;
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const unsigned n = mesh->mFaces[f].mNumIndices;
      if (n == 0) continue;
      types |= static_cast<unsigned>(n == 1   ? aiPrimitiveType_POINT
                                     : n == 2 ? aiPrimitiveType_LINE
                                     : n == 3 ? aiPrimitiveType_TRIANGLE
                                              : aiPrimitiveType_POLYGON);
    }
    // No types at all makes the step look at every face again, empty ones included.
    mesh->mPrimitiveTypes = types ? types : static_cast<unsigned>(aiPrimitiveType_POINT);
  }
  scene = importer.ApplyPostProcessing(aiProcess_Triangulate);
  if (!scene) throw assimp_error();

  // COLLADA: assimp's root node is the <visual_scene>, which has no transform of its own in the
  // format; the loader puts there its unit scale (and, without the property above, its up-axis
  // rotation), which assimp versions do differently. Drop it and apply the file's unit once.
  // (A COLLADA file found only by assimp, e.g. zipped .zae, keeps assimp's root transform: its
  // text is not at hand; the up-axis property still applies.)
  if (!collada && is_collada(scene)) {
    const std::string text = read_all(path);
    if (detail::looks_like_collada(text)) {
      collada = true;
      unit = detail::check_collada(path, text);
    }
  }

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

  return detail::build_mesh(std::move(vertices), std::move(faces), path, options, fail, unit);
}

}  // namespace pairgrasp
