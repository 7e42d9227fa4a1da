#pragma once
// Shared declarations of the binding areas. Each bind_<area>.cpp defines one function.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

namespace pairgrasp::py {
namespace pyb = pybind11;
void bind_errors(pyb::module_& m);     // bind_errors.cpp: FileError -> pairgrasp.FileError(RuntimeError)
void bind_mesh(pyb::module_& m);       // bind_mesh.cpp: Mesh, load_mesh, make_mesh
void bind_hand(pyb::module_& m);       // bind_hand.cpp: Hand, load_hand, Constellation
void bind_paint(pyb::module_& m);      // bind_paint.cpp: paint files -> per-face free mask
void bind_surface(pyb::module_& m);    // bind_surface.cpp: tessellate, UnitFacets, pair_feature, PairIndex
void bind_alignment(pyb::module_& m);  // bind_alignment.cpp: solve_pair_pose, Aligner
void bind_validation(pyb::module_& m); // bind_validation.cpp: SurfaceQuery, occluded_by, visible_from, GraspChecker
}  // namespace pairgrasp::py
