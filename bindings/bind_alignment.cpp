#include "bind.hpp"

namespace pairgrasp::py {

void bind_alignment(pyb::module_& m) { (void)m; }

}  // namespace pairgrasp::py
