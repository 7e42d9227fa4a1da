// libFuzzer harness: load_paint() for the bundled box target.
#include "fuzz_targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  pairgrasp::fuzz::paint_target(data, size);
  return 0;
}
