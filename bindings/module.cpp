// The pairgrasp._core extension: one bind_<area>() per area, each in its own file.
#include "bind.hpp"

#include <pairgrasp/version.hpp>

PYBIND11_MODULE(_core, m) {
  m.doc() = "pairgrasp C++ core: meshes, hands, unit facets, pair index, alignment, grasp quality.";
  m.def("version", &pairgrasp::version, "The library version.");
  pairgrasp::py::bind_errors(m);
  pairgrasp::py::bind_mesh(m);
  pairgrasp::py::bind_hand(m);
  pairgrasp::py::bind_paint(m);
  pairgrasp::py::bind_surface(m);
  pairgrasp::py::bind_alignment(m);
  pairgrasp::py::bind_query(m);
  pairgrasp::py::bind_collision(m);
  pairgrasp::py::bind_quality(m);
  pairgrasp::py::bind_planning(m);
  pairgrasp::py::bind_search(m);
}
