#pragma once
// suggest_edge() and build_target_index() (pair_index.hpp) that hand over the tessellation: the
// planner suggests its edge and then indexes at that edge, and the second tessellation cost tens of
// milliseconds (73 ms on the bundled mug at 5 mm, eight times counting its pairs there).
#include <pairgrasp/pair_index.hpp>

#include <optional>

namespace pairgrasp::detail {

/// suggest_edge(), and in `facets` (when not null) tessellate(mesh, edge, free_faces) at the edge
/// returned, when it made that tessellation on the way (left empty otherwise).
double suggest_edge(const Mesh& mesh, double d_max, std::size_t max_pairs, const Mask& free_faces, double min_edge,
                    std::optional<UnitFacets>* facets);

/// build_target_index(), indexing `facets` when given (which must be tessellate(mesh, edge,
/// free_faces)) instead of tessellating again.
TargetIndex build_target_index(const Mesh& mesh, double edge, const Mask& free_faces, const PairIndexOptions& options,
                               std::optional<UnitFacets> facets);

}  // namespace pairgrasp::detail
