#pragma once
// Shared declarations of the binding areas. Each bind_<area>.cpp defines one function.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <pairgrasp/candidates.hpp>
#include <pairgrasp/collision.hpp>
#include <pairgrasp/free_surface.hpp>
#include <pairgrasp/types.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace pairgrasp::py {
namespace pyb = pybind11;

/// A read-only NumPy view of an Eigen block held by `owner` (the view keeps `owner` alive).
/// Column vectors give 1-D arrays; an empty block gives a fresh empty array of the right shape.
template <class M>
pyb::array readonly_view(const M& m, pyb::handle owner) {
  using S = typename M::Scalar;
  const auto s = static_cast<pyb::ssize_t>(sizeof(S));
  if (m.size() == 0) {
    if (M::ColsAtCompileTime == 1) return pyb::array_t<S>(std::vector<pyb::ssize_t>{0});
    return pyb::array_t<S>(std::vector<pyb::ssize_t>{0, static_cast<pyb::ssize_t>(m.cols())});
  }
  pyb::array a;
  if (M::ColsAtCompileTime == 1)
    a = pyb::array_t<S>({static_cast<pyb::ssize_t>(m.rows())}, {s * m.innerStride()}, m.data(), owner);
  else
    a = pyb::array_t<S>({static_cast<pyb::ssize_t>(m.rows()), static_cast<pyb::ssize_t>(m.cols())},
                        {s * m.rowStride(), s * m.colStride()}, m.data(), owner);
  a.attr("setflags")(pyb::arg("write") = false);
  return a;
}

/// "(4, 3)" / "(4,)": an array's shape for error messages.
inline std::string shape_of(const pyb::array& a) {
  std::string s = "(";
  for (pyb::ssize_t k = 0; k < a.ndim(); ++k) s += (k ? ", " : "") + std::to_string(a.shape(k));
  return s + (a.ndim() == 1 ? ",)" : ")");
}
/// A C-contiguous float64 array.
using DoubleArray = pyb::array_t<double, pyb::array::c_style | pyb::array::forcecast>;

/// Anything NumPy converts, as float64; std::invalid_argument("<name>: ...") otherwise.
inline DoubleArray as_double_array(const pyb::handle& obj, const std::string& name) {
  pyb::object arr;
  try {
    arr = pyb::module_::import("numpy").attr("asarray")(obj, pyb::arg("dtype") = "float64");
  } catch (const pyb::error_already_set&) {
    throw std::invalid_argument(name + ": expected an array of numbers");
  }
  return DoubleArray::ensure(arr);
}

/// (N,3) points from anything NumPy converts.
inline Points points_from(const pyb::handle& obj, const std::string& name) {
  const DoubleArray a = as_double_array(obj, name);
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw std::invalid_argument(name + ": expected an (N, 3) array, got shape " + shape_of(a));
  Points p(a.shape(0), 3);
  std::copy(a.data(), a.data() + a.size(), p.data());
  return p;
}

/// A 1-D vector from anything NumPy converts.
inline Eigen::VectorXd vector_from(const pyb::handle& obj, const std::string& name) {
  const DoubleArray a = as_double_array(obj, name);
  if (a.ndim() != 1) throw std::invalid_argument(name + ": expected a 1-D array, got shape " + shape_of(a));
  Eigen::VectorXd v(a.shape(0));
  std::copy(a.data(), a.data() + a.size(), v.data());
  return v;
}
/// A rigid pose from 16 row-major doubles; std::invalid_argument("<name>: ...") unless rigid.
inline Pose pose_from_data(const double* d, const std::string& name) {
  Pose p;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) p.matrix()(i, j) = d[4 * i + j];
  check_rigid(p, name.c_str());
  return p;
}

/// A rigid pose from a 4x4 array.
inline Pose pose_from(const pyb::handle& obj, const std::string& name) {
  const DoubleArray a = as_double_array(obj, name);
  if (a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4)
    throw std::invalid_argument(name + ": expected a 4x4 array, got shape " + shape_of(a));
  return pose_from_data(a.data(), name);
}

/// A per-face mask from a 1-D bool array (None: nothing); std::invalid_argument("<name>: ...").
/// An option value given as a Python integer / real number; ValueError naming the option otherwise.
inline int integer(const pyb::handle& v, const std::string& name) {
  if (pyb::isinstance<pyb::bool_>(v) || !pyb::hasattr(v, "__index__"))
    throw std::invalid_argument(name + ": expected an integer, got " + std::string(pyb::repr(v)));
  const pyb::int_ i(pyb::reinterpret_borrow<pyb::object>(v));
  if (i < pyb::int_(std::numeric_limits<int>::min()) || i > pyb::int_(std::numeric_limits<int>::max()))
    throw std::invalid_argument(name + ": " + std::string(pyb::repr(v)) + " is out of range");
  return i.cast<int>();
}

/// A seed: an integer in [0, 2^64).
inline std::uint64_t seed_value(const pyb::handle& v, const std::string& name) {
  if (pyb::isinstance<pyb::bool_>(v) || !pyb::hasattr(v, "__index__"))
    throw std::invalid_argument(name + ": expected an integer, got " + std::string(pyb::repr(v)));
  const pyb::int_ i(pyb::reinterpret_borrow<pyb::object>(v));
  if (i < pyb::int_(0) || i > pyb::int_(std::numeric_limits<std::uint64_t>::max()))
    throw std::invalid_argument(name + ": expected an integer in [0, 2**64), got " + std::string(pyb::repr(v)));
  return i.cast<std::uint64_t>();
}

inline double real(const pyb::handle& v, const std::string& name) {
  if (pyb::isinstance<pyb::bool_>(v) || !pyb::hasattr(v, "__float__"))
    throw std::invalid_argument(name + ": expected a number, got " + std::string(pyb::repr(v)));
  return pyb::float_(pyb::reinterpret_borrow<pyb::object>(v)).cast<double>();
}

/// (K, D) DOF samples of a hand with `dofs` DOFs; ValueError ("samples: ...") for another shape.
inline std::vector<Eigen::VectorXd> samples_from(const pyb::handle& obj, long dofs) {
  const DoubleArray a = as_double_array(obj, "samples");
  if (a.ndim() != 2 || a.shape(1) != dofs)
    throw std::invalid_argument("samples: expected a (K, " + std::to_string(dofs) + ") array, got shape " + shape_of(a));
  std::vector<Eigen::VectorXd> out;
  for (pyb::ssize_t k = 0; k < a.shape(0); ++k) out.emplace_back(Eigen::Map<const Eigen::VectorXd>(a.data() + dofs * k, dofs));
  return out;
}

std::optional<Mask> mask_from(const pyb::handle& obj, const std::string& name);  // bind_query.cpp
/// Meshes from a list of Mesh (None: none); std::invalid_argument("<name>[i]: ...").
std::vector<Mesh> meshes_from(const pyb::handle& obj, const std::string& name);  // bind_query.cpp
/// The Occlusion of the keyword arguments free_surface() and GraspPlanner take.
Occlusion occlusion_from(const pyb::handle& paint, const pyb::handle& regions, const pyb::handle& occluders,
                         double distance, const pyb::handle& viewpoints, const pyb::handle& support);  // bind_paint.cpp
/// Obstacles from a list of Mesh, of (name, Mesh) pairs, or a dict name -> Mesh (None: none).
std::vector<Obstacle> obstacles_from(const pyb::handle& obj);  // bind_collision.cpp

/// A (F,) bool NumPy array of a mask.
inline pyb::array_t<bool> mask_to_numpy(const Mask& m) {
  pyb::array_t<bool> a(m.size());
  std::copy(m.data(), m.data() + m.size(), a.mutable_data());
  return a;
}


void bind_errors(pyb::module_& m);     // bind_errors.cpp: FileError -> pairgrasp.FileError(RuntimeError)
void bind_mesh(pyb::module_& m);       // bind_mesh.cpp: Mesh, load_mesh, make_mesh
void bind_hand(pyb::module_& m);       // bind_hand.cpp: Hand, load_hand, Constellation
void bind_paint(pyb::module_& m);      // bind_paint.cpp: paint files, the free surface (occluders, viewpoints, support)
void bind_surface(pyb::module_& m);    // bind_surface.cpp: tessellate, UnitFacets, pair_feature, PairIndex
void bind_alignment(pyb::module_& m);  // bind_alignment.cpp: solve_pair_pose, Aligner
void bind_query(pyb::module_& m);      // bind_query.cpp: SurfaceQuery
void bind_collision(pyb::module_& m);  // bind_collision.cpp: GraspChecker, close, contacts, closing_directions
void bind_quality(pyb::module_& m);    // bind_quality.cpp: contact wrenches, grasp quality (epsilon)
void bind_planning(pyb::module_& m);   // bind_planning.cpp: evaluate_grasp, fine_tune, CandidatePipeline, GraspPlanner
void bind_search(pyb::module_& m);     // bind_search.cpp: GraspSearch, plan_samples
/// The deadline `seconds` from now (negative: now), or none.
inline std::optional<std::chrono::steady_clock::time_point> deadline_after(std::optional<double> seconds) {
  if (!seconds) return std::nullopt;
  return std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                std::chrono::duration<double>(std::max(0.0, *seconds)));
}

/// Runs `finish(&timings)` without the GIL; returns (grasps, {'fine_tune', 'robust'} seconds).
template <class Finish>
pyb::tuple finish_released(Finish&& finish) {
  FinishTimings t;
  std::vector<RankedGrasp> grasps;
  {
    pyb::gil_scoped_release release;
    grasps = finish(&t);
  }
  using namespace pybind11::literals;
  return pyb::make_tuple(grasps, pyb::dict("fine_tune"_a = t.fine_tune, "robust"_a = t.robust));
}

}  // namespace pairgrasp::py
