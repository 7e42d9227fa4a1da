#pragma once
// What the two sources of the Aligner share (aligner.cpp: the pair votes; aligner_antipodal.cpp:
// the parallel jaw's grasp lines).
#include <pairgrasp/pair_index.hpp>
#include <pairgrasp/types.hpp>

namespace pairgrasp::detail {

// The facet size h used to make variances dimensionless: the index's spacing, or d_max / 10 for
// an index too small to have one.
double reference_spacing(const PairIndex& index);

// Throws std::invalid_argument naming the argument for a constellation of fewer than 2 samples,
// mismatched shapes, non-finite values or non-unit normals.
void check_constellation(const Points& points, const Points& normals);

}  // namespace pairgrasp::detail
