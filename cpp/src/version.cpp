#include <pairgrasp/version.hpp>

#ifndef PAIRGRASP_VERSION
#define PAIRGRASP_VERSION "unknown"
#endif

namespace pairgrasp {
const char* version() { return PAIRGRASP_VERSION; }
}  // namespace pairgrasp
