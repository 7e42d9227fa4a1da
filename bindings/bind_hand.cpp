#include "bind.hpp"

namespace pairgrasp::py {

void bind_hand(pyb::module_& m) { (void)m; }

}  // namespace pairgrasp::py
