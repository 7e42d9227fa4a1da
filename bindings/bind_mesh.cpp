#include "bind.hpp"

namespace pairgrasp::py {

void bind_mesh(pyb::module_& m) { (void)m; }

}  // namespace pairgrasp::py
