#pragma once
/// @file reachability.hpp
/// Per-face free masks of a target from the scene around it: faces near or inside an occluder
/// (a table, the hand holding an instrument) and faces no viewpoint sees are occluded.
///
/// Every function returns a **free** mask, one entry per face of the target (true = free,
/// reachable), combined by AND with an optional incoming mask (a paint file's). A result with no
/// free face is an error: std::invalid_argument whose message starts with "no free face left: ".
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/types.hpp>

#include <vector>

namespace pairgrasp {

/// Free mask of `target`: a face is occluded when some point of it lies within `distance`
/// (metres, >= 0) of an occluder's surface (exact triangle-to-triangle distance; intersecting
/// faces are at distance 0) or when it lies inside a closed occluder. Open occluders (a table
/// given as a plane) occlude by distance only. The result is ANDed with `free` (empty: all free).
///
/// Throws std::invalid_argument for a negative or non-finite distance ("distance: ..."), a
/// `free` mask of the wrong size ("free: expected F, got n"), an occluder with no faces, or when
/// no face is left free ("no free face left: ...").
Mask occluded_by(const Mesh& target, const std::vector<Mesh>& occluders, double distance,
                 const Mask& free = Mask(), int threads = 0);

/// Free mask of `target`: a face is free when some viewpoint sees it. A face is seen from a
/// viewpoint v when the face is front-facing (its outward normal n has n·(v − s) > 0) and the
/// segment from a sample point s of the face to v meets no other face of the target and no
/// occluder. Samples: the centroid and the three points 80 % of the way from the centroid to each
/// corner (so a face that is only partly hidden still counts as seen). The result is ANDed with
/// `free` (empty: all free).
///
/// Throws std::invalid_argument for no viewpoints or a non-finite one ("viewpoints: ..."), a
/// `free` mask of the wrong size, an occluder with no faces, or when no face is left free
/// ("no free face left: ...").
Mask visible_from(const Mesh& target, const Points& viewpoints, const Mask& free = Mask(),
                  const std::vector<Mesh>& occluders = {}, int threads = 0);

/// AND of two free masks of the same size. Throws std::invalid_argument for different sizes
/// ("b: expected F, got n") or when no face is left free ("no free face left: ...").
Mask combine_free(const Mask& a, const Mask& b);

}  // namespace pairgrasp
