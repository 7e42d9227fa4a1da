#pragma once
/// @file graspable.hpp
/// Where on a target a force-closure grasp can be at all: a necessary condition from the contacts'
/// friction cones and the hand's span, checked on the free surface before anything large is built.
///
/// The contacts of one grasp lie within the hand's contact span of each other, and the contact
/// forces of a force-closure grasp, each within its friction cone (half angle atan(mu)) about the
/// inward normal -n, must positively span R^3. So when every inward normal of the free surface
/// within `span` of a point x lies within 90 deg - atan(mu) of one direction v, every force any
/// contact near x can push has a positive component along v: no force-closure grasp has a contact
/// at x. A 1.5 m box's faces, at most three of which meet within a hand's span, and a lone flat
/// sheet are such surfaces everywhere; a hand-sized closed object nowhere.
///
/// Lengths are metres, angles radians.
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/types.hpp>

#include <cstddef>

namespace pairgrasp {

/// The free faces that may hold a contact of a force-closure grasp (graspable_faces()).
struct GraspableFaces {
  Mask faces;                 ///< per face of the mesh: free and graspable
  std::size_t free = 0;       ///< free faces
  std::size_t graspable = 0;  ///< free faces that are graspable
  /// The widest cone (half angle, radians) that held the inward normals near a point found
  /// ungraspable, or 0 when none was: the figure a refusal names.
  double widest_cone = 0.0;
  /// The largest cone half angle (radians) the normals near a point may fit in for it to be
  /// ungraspable: pi/2 - atan(mu) less the binning margin.
  double limit = 0.0;
};

/// Which free faces of `mesh` may hold a contact of a force-closure grasp whose contacts all lie
/// within `span` (m) of each other, with friction coefficient `mu` (`free`: per face, empty: all).
///
/// Method: the free faces are sampled at spacing s = span/12 (corners included), each sample
/// keeping its face's inward normal, binned on a cube map of 6 x 32 x 32 directions (every
/// direction of a bin within r_b, about 2.6 degrees, of its centre), per cubic cell of edge s. A
/// point of a face lies within s of one of its samples, which lies within s sqrt(3)/2 of its cell's
/// centre; so the cells whose centres lie within span + (2 + sqrt(3)) s of a cell's centre hold
/// every normal within span of the points that cell's samples stand for. The cell is hopeless when
/// the mean of those bins' centres is long enough and one direction, found from it by Badoiu-Clarkson
/// steps towards the minimum enclosing cap, lies within 90 deg - atan(mu) - r_b of every centre
/// (any direction found is a proof). A face is left out only when every cell of its samples is
/// hopeless. So only what provably cannot be in a force-closure grasp is left out (torques are not
/// considered: a necessary condition); the slack makes the test look up to 1.31 span away.
/// Deterministic; uses `threads` (0: every core).
///
/// Throws std::invalid_argument for a non-positive or non-finite span, a negative or non-finite mu,
/// a mask of the wrong size or a mesh with non-finite vertices.
GraspableFaces graspable_faces(const Mesh& mesh, const Mask& free, double span, double mu, int threads = 0);

}  // namespace pairgrasp
