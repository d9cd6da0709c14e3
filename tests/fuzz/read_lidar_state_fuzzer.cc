// libFuzzer target for the saved LiDAR state reader (and the writer behind it). Built by
// benchmarks/fuzz.sh with clang, -fsanitize=fuzzer,address,undefined.
#include "read_lidar_state_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return tether::fuzz::ReadLidarStateOnce(data, size);
}
