// Error policy in Python: FileError -> pairgrasp.FileError (a RuntimeError subclass);
// std::invalid_argument and BudgetError (derived from it) -> ValueError, pybind11's own mapping.
#include "bind.hpp"

#include <pairgrasp/error.hpp>

namespace pairgrasp::py {

void bind_errors(pyb::module_& m) {
  static pyb::exception<FileError> file_error(m, "FileError", PyExc_RuntimeError);
  file_error.doc() = "A user file (mesh, URDF, hand spec, paint) is missing, unreadable or malformed.";
  // pybind11 maps std::invalid_argument to ValueError already; BudgetError derives from it.
  pyb::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const FileError& e) {
      PyErr_SetString(file_error.ptr(), e.what());
    }
  });
}

}  // namespace pairgrasp::py
