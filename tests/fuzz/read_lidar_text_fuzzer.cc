// libFuzzer target for the TUM and relations readers and the bag record check. Built by
// benchmarks/fuzz.sh with clang, -fsanitize=fuzzer,address,undefined.
#include "read_lidar_text_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return tether::fuzz::ReadLidarTextOnce(data, size);
}
