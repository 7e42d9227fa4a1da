#include "bind.hpp"

namespace pairgrasp::py {

void bind_paint(pyb::module_& m) { (void)m; }

}  // namespace pairgrasp::py
