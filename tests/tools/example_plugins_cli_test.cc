// The command-line program with the example plugins (plugins/examples/range_2d and
// position_prior): `tether optimize --plugin` reads their tags, solves, and writes them back.
// The plugins' own tests, through the library, are in tests/solvers/example_plugins_test.cc.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/plugins/plugin_loader.h"

namespace tether {
namespace {

std::string PluginPath(const std::string& name) { return std::string(TETHER_PLUGIN_BUILD_DIR) + "/" + name + ".so"; }

// The command-line program with both example plugins: reads their tags, solves, writes them back.
TEST(ExamplePluginsCliTest, OptimizeReadsAndWritesPluginTags) {
  const std::string base = ::testing::TempDir() + "example_plugins_cli_" + std::to_string(getpid());
  const std::string in = base + ".g2o", out = base + "_out.g2o", log = base + ".log";
  {
    std::ofstream f(in);
    f << "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1.1 0.1 0.05\nVERTEX_SE2 2 2.1 -0.1 -0.05\n"
         "VERTEX_XY 10 1 5\nFIX 10\n"
         "EDGE_SE2 0 1 1 0 0 100 0 0 100 0 100\nEDGE_SE2 1 2 1 0 0 100 0 0 100 0 100\n"
         "EDGE_RANGE_SE2_XY 0 10 5.0990195135927845 100\nEDGE_RANGE_SE2_XY 1 10 5 100\n"
         "EDGE_RANGE_SE2_XY 2 10 5.0990195135927845 100\n"
         "EDGE_POSITION_PRIOR_SE2 0 0 0 100 0 100\n";
  }
  const std::string command = std::string(TETHER_CLI) + " optimize -q --plugin " + PluginPath("range_2d") +
                              " --plugin " + PluginPath("position_prior") + " " + in + " -o " + out + " > " + log +
                              " 2>&1";
  const int status = std::system(command.c_str());
  auto slurp = [](const std::string& path) {
    std::ifstream f(path);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
  };
  const std::string written = slurp(out), output = slurp(log);
  for (const std::string& path : {in, out, log}) std::remove(path.c_str());
  ASSERT_EQ(status, 0) << command << "\n" << output;
  // One line per plugin, the count in words that agree with it.
  EXPECT_NE(output.find("loaded plugin range_2d"), std::string::npos) << output;
  EXPECT_NE(output.find("(1 factor type)\n"), std::string::npos) << output;
  EXPECT_NE(output.find("(2 factor types)\n"), std::string::npos) << output;
  EXPECT_NE(written.find("EDGE_RANGE_SE2_XY 0 10 5.0990195135927845 100\n"), std::string::npos) << written;
  EXPECT_NE(written.find("EDGE_POSITION_PRIOR_SE2 0 0 0 100 0 100\n"), std::string::npos) << written;
  // The solution: poses at (0,0), (1,0), (2,0) with the beacon at (1, 5).
  std::istringstream back(written);
  Registry registry;
  RegisterBuiltinFactors(registry);
  PluginLoader loader(registry);
  loader.Load(PluginPath("range_2d"));
  loader.Load(PluginPath("position_prior"));
  const GraphFile solved = ReadGraph(back, out, registry);
  EXPECT_NEAR(solved.values.At<SE2d>(2).x(), 2.0, 1e-6);
  EXPECT_NEAR(solved.values.At<SE2d>(2).y(), 0.0, 1e-6);
}

}  // namespace
}  // namespace tether
