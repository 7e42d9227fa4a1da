// libFuzzer harness: Hand::load() on a hand spec and its URDF (see fuzz_targets.hpp).
#include "fuzz_targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  pairgrasp::fuzz::hand_target(data, size);
  return 0;
}
