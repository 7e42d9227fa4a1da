// libFuzzer harness: load_mesh() on one mesh format (PAIRGRASP_FUZZ_EXT, e.g. ".stl").
#include "fuzz_targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  pairgrasp::fuzz::mesh_target(PAIRGRASP_FUZZ_EXT, data, size);
  return 0;
}
