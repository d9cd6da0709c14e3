// Replays the fuzz targets' inputs in the normal build: every file in tests/fuzz/regressions
// (each finding of benchmarks/fuzz.sh is kept there, with the fix) and hand-made hostile
// inputs, through the same body the fuzzers run (a finding aborts the test).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "fuzz/read_graph_fuzz.h"

namespace tether {
namespace {

namespace fs = std::filesystem;
using namespace std::string_literals;

void Replay(const std::string& bytes, FileFormat format) {
  fuzz::ReadGraphOnce(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size(), format);
}

TEST(FuzzRegressionTest, EveryKeptInputReadsOrIsRefusedCleanly) {
  const fs::path dir = fs::path(TETHER_SOURCE_DIR) / "tests/fuzz/regressions";
  int replayed = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file() || e.path().filename() == "README.md") continue;
    std::ifstream in(e.path(), std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    SCOPED_TRACE(e.path().filename().string());
    const std::string name = e.path().filename().string();
    const bool toro = name.find("toro") != std::string::npos, isam = name.find("isam") != std::string::npos;
    Replay(s.str(), toro ? FileFormat::kToro : isam ? FileFormat::kIsam : FileFormat::kG2o);
    ++replayed;
  }
  EXPECT_GT(replayed, 0) << "no regression inputs in " << dir;
}

TEST(FuzzRegressionTest, HostileInputsAreRefusedCleanly) {
  const std::vector<std::string> inputs = {
      "\0"s,
      "\0VERTEX_SE2 18446744073709551615 0 0 0\nVERTEX_SE2 0 0 0 0\nEDGE_SE2 18446744073709551615 0 1 0 0 1 0 0 1 0 1\n"s,
      "\0VERTEX_SE2 0 1e308 -1e308 1e308\n"s,
      "\0EDGE_SE2 0 1 1 0 0 1e155 0 0 1e155 0 1e155\n"s,
      "\0EDGE_SE2 0 1 1 0 0 1.23456789e-170 0 0 1.23456789e-170 0 1.23456789e-170\n"s,
      "\4EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nVERTEX_SE2 5 0 0 0\nFIX 5\n"s,
      "\1EDGE_SE2 0 1 1 0 0 1 0 0 -1 0 1\n"s,
      "\2EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 0 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\n"s,
      "\0VERTEX_SWITCH 3 2\nEDGE_SWITCH_PRIOR 3 1 1\n"s,
      "\0ODOMETRY 0 1 1 0 0 1e200 0 0 1e200 0 1e200\nLANDMARK 1 0 1 1 1e-200 0 1e-200\n"s,
      "\100LANDMARK 1 0 1 1 1e-300 0 1e-300\nODOMETRY 0 1 1 0 0 1e308 1e308 0 1e308 0 1e308\n"s,
      "\200ODOMETRY 0 5 1 0 0 1 0 0 1 0 1\nLANDMARK 5 0 1 1 1 0 1\n"s,
      "\0VERTEX2 0 0 0 0\nBR 0 18446744073709551615 1 1 1 1\nBR 0 1 1e308 1e308 1e-200 1e200\n"s,
      "\0PARAMS_SE3OFFSET 0 1e300 0 0 1e200 0 0 1\nEDGE_SE3_TRACKXYZ 0 1 0 1e300 0 0 1 0 0 1 0 1\n"s,
      "\0EDGE_RANGE_BEARING_SE2_XY 0 1 1e308 1e308 1 0 1\n"s,
  };
  for (const std::string& in : inputs) {
    SCOPED_TRACE(in.substr(1, 60));
    Replay(in, FileFormat::kG2o);
    Replay(in, FileFormat::kToro);
    Replay(in, FileFormat::kIsam);
  }
}

}  // namespace
}  // namespace tether
