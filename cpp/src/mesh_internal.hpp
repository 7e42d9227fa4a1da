#pragma once
// Internal: the validation and clean-up shared by load_mesh() and make_mesh().
#include <pairgrasp/mesh.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace pairgrasp::detail {

/// Reports a defect of the input. `argument` is "vertices" or "faces"; `message` says what is
/// wrong ("vertex 3 is not finite (nan, 0, 0)"). Must throw.
using MeshFail = std::function<void(const std::string& argument, const std::string& message)>;

/// Throws std::invalid_argument for a non-finite or non-positive scale or a negative or
/// non-finite weld tolerance.
void check_mesh_options(const MeshLoadOptions& options);

/// Validates, scales (by `unit * options.scale`), welds, removes degenerate and duplicate faces,
/// drops unused vertices, orients and measures. Every defect goes through `fail`.
Mesh build_mesh(Points vertices, Triangles faces, std::string source, const MeshLoadOptions& options,
                const MeshFail& fail, double unit = 1.0);

/// True when `head` (the first bytes of a file) starts with the PLY magic line.
bool has_ply_magic(const std::string& head);

/// Parses the PLY file `path` whose whole contents are `data` (ASCII, binary little- or
/// big-endian): the x, y, z of element "vertex" and the "vertex_indices" (or "vertex_index")
/// lists of element "face", polygons triangulated. Throws FileError naming the header line,
/// body line (ASCII) or byte offset (binary) at fault; checks counts against the file size.
void read_ply(const std::string& path, const std::string& data, Points& vertices, Triangles& faces);

/// Appends the triangles of the planar polygon `poly` (indices into `vertices`, all in range),
/// keeping its winding: ear clipping in the plane of its Newell normal, a fan when that fails.
void triangulate_polygon(const Points& vertices, const std::vector<std::int64_t>& poly,
                         std::vector<std::array<std::int64_t, 3>>& out);

/// True when `head` (the first bytes of a file) holds a <COLLADA> element.
bool looks_like_collada(const std::string& head);

/// Checks the COLLADA document `text` of file `path` for what assimp 5.2 cannot survive (see
/// mesh_collada.cpp) and returns its unit in metres (`<asset><unit meter>`, 1 when absent).
/// Throws FileError naming the line at fault.
double check_collada(const std::string& path, const std::string& text);

}  // namespace pairgrasp::detail
