// A step strategy from a plugin selected on the command line: `tether optimize --plugin
// test_step_strategy.so --solver gn-halving` uses it, and without the plugin the name is a
// usage error. Through the library: tests/frontends/step_strategy_plugin_test.cc.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include "testing/simulated.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"

namespace tether {
namespace {

std::string TestPlugin(const std::string& name) {
  return std::string(TETHER_TEST_PLUGIN_DIR) + "/test_" + name + ".so";
}

TEST(StepStrategyPluginTest, TheCommandLineSelectsIt) {
  const SimulatedGraph sim = testing::SimulateWorld(SimWorld::kManhattan, 200, 5);
  const std::string dir = ::testing::TempDir();
  const std::string in = dir + "/strategy_in.g2o", log = dir + "/strategy_cli.txt";
  WriteG2oFile(in, sim.initial, sim.graph, DefaultRegistry());
  const std::string cli = std::string(TETHER_CLI) + " optimize " + in + " -q --plugin " + TestPlugin("step_strategy");
  ASSERT_EQ(std::system((cli + " --solver gn-halving > " + log + " 2>&1").c_str()), 0);
  std::ifstream f(log);
  const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("step strategy 'gn-halving'"), std::string::npos) << text;
  EXPECT_NE(text.find("converged"), std::string::npos) << text;
  // Without the plugin the name is unknown: a usage error naming the choices.
  const int code =
      std::system((std::string(TETHER_CLI) + " optimize " + in + " -q --solver gn-halving > " + log + " 2>&1").c_str());
  EXPECT_EQ(WEXITSTATUS(code), 2);
}

}  // namespace
}  // namespace tether
