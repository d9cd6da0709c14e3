// libFuzzer target for the graph readers: g2o (TETHER_FUZZ_FORMAT_G2O), iSAM's landmark format
// (TETHER_FUZZ_FORMAT_ISAM) or TORO with BR lines (otherwise).
// Built by benchmarks/fuzz.sh with clang, -fsanitize=fuzzer,address,undefined.
#include "read_graph_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
#if defined(TETHER_FUZZ_FORMAT_G2O)
  return tether::fuzz::ReadGraphOnce(data, size, tether::FileFormat::kG2o);
#elif defined(TETHER_FUZZ_FORMAT_ISAM)
  return tether::fuzz::ReadGraphOnce(data, size, tether::FileFormat::kIsam);
#else
  return tether::fuzz::ReadGraphOnce(data, size, tether::FileFormat::kToro);
#endif
}
