// libFuzzer target for the CARMEN laser-log reader (and the writer and degrader behind it).
// Built by benchmarks/fuzz.sh with clang, -fsanitize=fuzzer,address,undefined.
#include "read_carmen_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return tether::fuzz::ReadCarmenOnce(data, size);
}
