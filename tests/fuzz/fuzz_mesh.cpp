// libFuzzer harness: load_mesh() on one mesh format (PAIRGRASP_FUZZ_EXT, e.g. ".stl").
#include "fuzz_targets.hpp"

// assimp 5.2 leaks a few objects on some error paths of malformed files; those are its own.
extern "C" const char* __lsan_default_suppressions() { return "leak:libassimp.so\n"; }

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  pairgrasp::fuzz::mesh_target(PAIRGRASP_FUZZ_EXT, data, size);
  return 0;
}
