// Replays the CARMEN fuzz target's inputs in the normal build: every file in
// tests/fuzz/regressions/carmen (each finding of benchmarks/fuzz.sh is kept there, with the fix)
// and hand-made hostile logs, through the same body the fuzzer runs (a finding aborts the test).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "fuzz/read_carmen_fuzz.h"
#include "fuzz/read_lidar_text_fuzz.h"

namespace tether {
namespace {

namespace fs = std::filesystem;
using namespace std::string_literals;

void Replay(const std::string& bytes) {
  fuzz::ReadCarmenOnce(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
}

TEST(CarmenFuzzRegressionTest, EveryKeptInputReadsOrIsRefusedCleanly) {
  const fs::path dir = fs::path(TETHER_SOURCE_DIR) / "tests/fuzz/regressions/carmen";
  int replayed = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file() || e.path().extension() == ".md") continue;
    std::ifstream in(e.path(), std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    SCOPED_TRACE(e.path().filename().string());
    Replay(s.str());
    ++replayed;
  }
  EXPECT_GT(replayed, 0) << "no regression inputs in " << dir;
  std::remove(fuzz::CarmenScratchPath().c_str());
}

TEST(CarmenFuzzRegressionTest, HostileLogsAreReadOrRefusedCleanly) {
  const std::string raw = "RAWLASER1 0 -1.5 1.5 0.75 40 0.01 0 3 1 2 3 0 10 h 1\n";
  const std::vector<std::string> logs = {
      "",
      "\n\n\n",
      raw,
      "ODOM 1e308 -1e308 1e308 0 0 0 10 h 1\n" + raw,
      "ROBOTLASER1 0 -1.5 1.5 0.75 40 0.01 0 3 1 2 3 0 1e308 0 0 1e308 0 0 0 0 0 0 0 10 h 1\n",
      "ROBOTLASER1 0 -1e308 1e308 1e308 1e308 0 0 3 1 2 3 0 0 0 0 0 0 0 0 0 0 0 0 10 h 1\n",
      "RAWLASER1 0 1e308 1e308 1e-320 1e-320 0 0 2 0 1e-320 0 1e308 h -1e308\n",
      "FLASER 2 0 0 1e308 1e308 1e308 -1e308 -1e308 -1e308 1e308 h 1\n",
      "ODOM 0 0 0 0 0 0 1 h 1\nODOM 1 0 0 0 0 0 1 h 1\n" + raw + "RAWLASER1 0 0 1 0.5 9 0 0 2 1 1 0 1 h 1\n",
      "RAWLASER1 0 -1.5 1.5 0.75 40 0.01 0 1048577 1\n",
      "RAWLASER1 0 -1.5 1.5 0.75 40 0.01 0 3 1 2 3 1048576 1\n",
  };
  for (const std::string& log : logs) {
    SCOPED_TRACE(log.substr(0, 80));
    for (int b = 0; b < 32; ++b) Replay(std::string(1, static_cast<char>(b)) + log);
  }
  std::remove(fuzz::CarmenScratchPath().c_str());
}

// The TUM, relations and bag-record fuzz target on hostile inputs: each reads or is refused
// with a tether::Error, and what reads round-trips (the target aborts otherwise).
TEST(LidarTextFuzzRegressionTest, HostileTextAndBagInputsAreReadOrRefusedCleanly) {
  const std::vector<std::string> inputs = {
      std::string("\0", 1),
      std::string("\0", 1) + "1e308 1e308 -1e308 0 0 0 0 1\n",
      std::string("\0", 1) + "1e245 1 2 0 0 0 0.3 0.9\n2e245 1 2 0 0 0 0.3 0.9\n",
      std::string("\0", 1) + "1 \x1b[2J 2 0 0 0 0 1\n",
      std::string("\0", 1) + "1 nan 2 0 0 0 0 1\n",
      "\x01"
      "1 2 1e308 0 0 0 0 1e308\n",
      "\x01"
      "2 1 0 0 0 0 0 0\n1 1 0 0 0 0 0 0\n",
      "\x02",
      "\x02"
      "#ROSBAG V2.0\n\xff\xff\xff\x7f",
      "\x02"
      "#ROSBAG V2.0\n\x08\0\0\0\x04\0\0\0op=\x05\xff\xff\xff\xff",
  };
  for (const std::string& in : inputs) {
    SCOPED_TRACE(in.substr(1, 60));
    EXPECT_EQ(fuzz::ReadLidarTextOnce(reinterpret_cast<const std::uint8_t*>(in.data()), in.size()), 0);
  }
  std::remove(fuzz::BagScratchPath().c_str());
}

}  // namespace
}  // namespace tether
