// `tether bench --plugin`: plugins are loaded before the files are read, so graphs with the
// plugins' tags can be timed, as `tether optimize --plugin` solves them.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "tether/tools/bench.h"
#include "tether/tools/commands.h"

namespace tether {
namespace {

namespace fs = std::filesystem;

std::string PluginPath(const std::string& name) { return std::string(TETHER_PLUGIN_BUILD_DIR) + "/" + name + ".so"; }

class BenchPluginTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tether_bench_plugin_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    // Three poses and a beacon ranged by the example plugin's EDGE_RANGE_SE2_XY.
    std::ofstream f(P("range.g2o"));
    f << "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1.1 0.1 0.05\nVERTEX_SE2 2 2.1 -0.1 -0.05\n"
         "VERTEX_XY 10 1 5\nFIX 10\n"
         "EDGE_SE2 0 1 1 0 0 100 0 0 100 0 100\nEDGE_SE2 1 2 1 0 0 100 0 0 100 0 100\n"
         "EDGE_RANGE_SE2_XY 0 10 5.0990195135927845 100\nEDGE_RANGE_SE2_XY 1 10 5 100\n"
         "EDGE_RANGE_SE2_XY 2 10 5.0990195135927845 100\n";
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string P(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

TEST_F(BenchPluginTest, TagsOfAPluginAreReadOnlyWithIt) {
  BenchCommand cmd;
  cmd.files = {P("range.g2o")};
  cmd.repeat = 1;
  cmd.format = "csv";
  cmd.init = "file";
  std::ostringstream out, err;
  // Without the plugin the tag is unknown: the row says bad input.
  EXPECT_EQ(RunBench(cmd, out, err), 1) << err.str();
  EXPECT_NE(out.str().find("bad-input"), std::string::npos) << out.str();
  EXPECT_NE(out.str().find("EDGE_RANGE_SE2_XY"), std::string::npos) << out.str();

  cmd.plugins = {PluginPath("range_2d")};
  out.str("");
  err.str("");
  EXPECT_EQ(RunBench(cmd, out, err), 0) << err.str() << out.str();
  EXPECT_NE(err.str().find("loaded plugin range_2d"), std::string::npos) << err.str();
  // The plugin's line goes with the progress (stderr) and before the first run.
  EXPECT_LT(err.str().find("loaded plugin range_2d"), err.str().find("run 1 of 1"));
  EXPECT_EQ(out.str().find("loaded plugin"), std::string::npos);
  EXPECT_NE(out.str().find(",converged,"), std::string::npos) << out.str();
}

TEST_F(BenchPluginTest, APluginThatCannotBeLoadedRunsNothing) {
  BenchCommand cmd;
  cmd.files = {P("range.g2o")};
  cmd.repeat = 1;
  cmd.plugins = {P("no_such_plugin.so")};
  std::ostringstream out, err;
  EXPECT_EQ(RunBench(cmd, out, err), kExitPluginFailed);
  EXPECT_NE(err.str().find("no_such_plugin"), std::string::npos) << err.str();
  EXPECT_EQ(err.str().find("run 1 of"), std::string::npos) << err.str();
  EXPECT_TRUE(out.str().empty()) << out.str();
}

#ifdef TETHER_CLI
TEST_F(BenchPluginTest, CommandLineOption) {
  const std::string command = std::string(TETHER_CLI) + " bench --repeat 1 --init file --format csv --plugin " +
                              PluginPath("range_2d") + " " + P("range.g2o") + " -o " + P("table.csv") + " 2>&1";
  FILE* p = popen(command.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string output;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof(buf), p)) > 0) output.append(buf, n);
  const int status = pclose(p);
  ASSERT_TRUE(WIFEXITED(status)) << output;
  EXPECT_EQ(WEXITSTATUS(status), 0) << output;
  EXPECT_NE(output.find("loaded plugin range_2d"), std::string::npos) << output;
  std::ifstream table(P("table.csv"));
  std::stringstream s;
  s << table.rdbuf();
  EXPECT_NE(s.str().find(",converged,"), std::string::npos) << s.str();
}
#endif

}  // namespace
}  // namespace tether
