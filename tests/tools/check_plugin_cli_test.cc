// `tether check-plugin PLUGIN.so`: every factor type the plugin registers is checked at random
// points; a Jacobian entry of the wrong sign is reported with the entry and exit 1; a plugin
// that will not load exits 5 naming it.
#include <gtest/gtest.h>

#include <string>

#include "testing/cli.h"

namespace tether {
namespace {

using testing::CliRun;
using testing::Tether;

std::string Example(const std::string& name) { return std::string(TETHER_PLUGIN_BUILD_DIR) + "/" + name + ".so"; }
std::string TestPlugin(const std::string& name) {
  return std::string(TETHER_TEST_PLUGIN_DIR) + "/test_" + name + ".so";
}

TEST(CheckPluginCliTest, TheExamplePluginsPass) {
  for (const char* plugin : {"range_2d", "position_prior", "odometry_scale"}) {
    CliRun r = Tether("check-plugin " + Example(plugin) + " --trials 50");
    EXPECT_EQ(r.code, 0) << plugin << ": " << r.output;
    EXPECT_NE(r.output.find("50 random points"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("MISMATCH"), std::string::npos) << r.output;
  }
  CliRun range = Tether("check-plugin " + Example("range_2d"));
  EXPECT_NE(range.output.find("100 random points"), std::string::npos) << range.output;
}

TEST(CheckPluginCliTest, AWrongJacobianEntryIsNamedAndFails) {
  CliRun r = Tether("check-plugin " + TestPlugin("wrong_jacobian"));
  EXPECT_EQ(r.code, 1) << r.output;
  // The right type passes, the wrong one fails at its flipped entry (row 0, tangent column 1).
  const std::size_t right = r.output.find("TestRightRange ");
  ASSERT_NE(right, std::string::npos) << r.output;
  EXPECT_EQ(r.output.substr(right, r.output.find('\n', right) - right).find(": ok"),
            r.output.find('\n', right) - right - 4)
      << r.output;
  EXPECT_NE(r.output.find("TestWrongRange: d e[0] / d delta_0[1]"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("MISMATCH at"), std::string::npos) << r.output;
  // Quiet: only what fails.
  CliRun quiet = Tether("check-plugin -q " + TestPlugin("wrong_jacobian"));
  EXPECT_EQ(quiet.code, 1);
  EXPECT_EQ(quiet.output.find("TestRightRange "), std::string::npos) << quiet.output;
  EXPECT_NE(quiet.output.find("TestWrongRange "), std::string::npos) << quiet.output;
}

TEST(CheckPluginCliTest, APluginThatWillNotLoadOrBadOptionsAreRefused) {
  CliRun missing = Tether("check-plugin " + TestPlugin("missing_entry"));
  EXPECT_EQ(missing.code, 5) << missing.output;
  EXPECT_NE(missing.output.find("test_missing_entry"), std::string::npos) << missing.output;
  CliRun trials = Tether("check-plugin " + Example("range_2d") + " --trials 0");
  EXPECT_EQ(trials.code, 2) << trials.output;
  EXPECT_NE(trials.output.find("--trials"), std::string::npos) << trials.output;
}

}  // namespace
}  // namespace tether
