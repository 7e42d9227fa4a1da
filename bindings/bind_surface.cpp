#include "bind.hpp"

namespace pairgrasp::py {

void bind_surface(pyb::module_& m) { (void)m; }

}  // namespace pairgrasp::py
