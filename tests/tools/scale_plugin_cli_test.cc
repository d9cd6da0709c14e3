// The odometry_scale example plugin through a g2o file and `tether optimize --plugin`: the
// file holds the plugin's tags, and the program solves the scale back from either start. The
// plugin through the library: tests/solvers/scale_plugin_test.cc.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include "testing/scale_world.h"
#include "tether/core/graph_io.h"

namespace tether {
namespace {

using testing::kScaleKey;
using testing::kTrueScale;
using testing::PositionRmse;
using testing::ScalePluginPath;
using testing::ScalePluginTest;
using testing::ScaleWorld;
using testing::SimulateScaleWorld;

TEST_F(ScalePluginTest, ThroughAFileAndTheCommandLine) {
  ScaleWorld w = SimulateScaleWorld(registry_);
  const std::string dir = ::testing::TempDir();
  const std::string in = dir + "/scale_in.g2o", out = dir + "/scale_out.g2o";
  WriteG2oFile(in, w.file.values, w.file.graph, registry_);
  {
    std::ifstream f(in);
    const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("VERTEX_SCALE 100000 1\n"), std::string::npos);
    EXPECT_NE(text.find("EDGE_SE2_SCALED 0 1 100000 "), std::string::npos);
  }
  // (The spanning-tree start composes measurements alone; this factor cannot predict a pose
  // without the scale, so that start refuses such a graph, naming the first pose it cannot reach.)
  for (const char* init : {"file", "chordal"}) {
    std::remove(out.c_str());
    const std::string cmd = std::string(TETHER_CLI) + " optimize " + in + " -o " + out + " --plugin " +
                            ScalePluginPath() + " --init " + init + " -q > " + dir + "/scale_cli.txt 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << init;
    const GraphFile g = ReadGraphFile(out, registry_);
    EXPECT_NEAR(*g.values.Params(kScaleKey), kTrueScale, 0.003) << init;
    EXPECT_LT(PositionRmse(g.values, w.truth), 0.1) << init;
  }
}

}  // namespace
}  // namespace tether
