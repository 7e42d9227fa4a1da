#pragma once
// Internal: the validation and clean-up shared by load_mesh() and make_mesh().
#include <pairgrasp/mesh.hpp>

#include <functional>
#include <string>

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

}  // namespace pairgrasp::detail
