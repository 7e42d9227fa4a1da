#pragma once
// What the two sources of the Aligner share (aligner.cpp: the pair votes; aligner_antipodal.cpp:
// the parallel jaw's grasp lines).
#include <pairgrasp/aligner.hpp>
#include <pairgrasp/pair_index.hpp>
#include <pairgrasp/types.hpp>

#include "thread_pool.hpp"

#include <stdexcept>
#include <string>
#include <vector>

namespace pairgrasp::detail {

// The facet size h used to make variances dimensionless: the index's spacing, or d_max / 10 for
// an index too small to have one.
double reference_spacing(const PairIndex& index);

// Throws std::invalid_argument naming the argument for a constellation of fewer than 2 samples,
// mismatched shapes, non-finite values or non-unit normals.
void check_constellation(const Points& points, const Points& normals);

// Aligns every constellation on `threads` workers, one per task: `check` (points, normals) first
// on all of them (its message prefixed with "constellations[k]: "), then `align` (points, normals,
// options with max_poses > 0 in place of the aligner's).
template <class Check, class Align>
std::vector<AlignResult> align_each(const std::vector<Constellation>& constellations, AlignerOptions options,
                                    int max_poses, int threads, Check check, Align align) {
  if (max_poses < 0)
    throw std::invalid_argument("max_poses: expected >= 0 (0: the aligner's), got " + std::to_string(max_poses));
  if (max_poses > 0) options.max_poses = max_poses;
  for (std::size_t k = 0; k < constellations.size(); ++k) {
    try {
      check(constellations[k].points, constellations[k].normals);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("constellations[" + std::to_string(k) + "]: " + e.what());
    }
  }
  std::vector<AlignResult> out(constellations.size());
  parallel_for(constellations.size(), resolve_threads(threads), [&](std::size_t k) {
    out[k] = align(constellations[k].points, constellations[k].normals, options);
  });
  return out;
}

}  // namespace pairgrasp::detail
