// libFuzzer's entry point for one target, chosen at compile time (LUNARNAV_FUZZ_TARGET, a
// function of tests/fuzz/targets.h). Built with LUNARNAV_FUZZ=ON (clang); run by scripts/fuzz.
#include <cstddef>
#include <cstdint>

#include "fuzz/targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  lunarnav::fuzz::LUNARNAV_FUZZ_TARGET(data, size);  // parsed or refused: both fine
  return 0;
}
