// tether replay on a small simulated Manhattan world: the exit codes, the printed fields, the
// final chi2 against the batch optimum, --every, --check and -o.
#include "tether/tools/replay.h"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>

#include "testing/simulated.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"

namespace tether {
namespace {

namespace fs = std::filesystem;

// "name: value ..." lines of the report, by name.
std::map<std::string, std::string> Fields(const std::string& report) {
  std::map<std::string, std::string> fields;
  std::istringstream in(report);
  std::string line;
  while (std::getline(in, line)) {
    const std::size_t colon = line.find(": ");
    if (colon != std::string::npos) fields[line.substr(0, colon)] = line.substr(colon + 2);
  }
  return fields;
}

class ReplayTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tether_replay_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    file_ = (dir_ / "manhattan.g2o").string();
    const SimulatedGraph sim = testing::SimulateWorld(SimWorld::kManhattan, 200, 3);
    factors_ = sim.graph.size();
    WriteG2oFile(file_, sim.initial, sim.graph, DefaultRegistry());
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
  std::string file_;
  std::size_t factors_ = 0;
};

TEST_F(ReplayTest, FinalChi2IsTheBatchOptimum) {
  for (int every : {1, 7}) {
    ReplayCommand cmd;
    cmd.input = file_;
    cmd.every = every;
    cmd.quiet = true;
    std::ostringstream out, err;
    ASSERT_EQ(RunReplay(cmd, out, err), 0) << err.str();
    const auto f = Fields(out.str());
    for (const char* name : {"updates", "total [s]", "per step [ms]", "final chi2", "batch optimum"}) {
      EXPECT_EQ(f.count(name), 1u) << name << " missing from\n" << out.str();
    }
    EXPECT_EQ(std::stoi(f.at("updates")), (200 + every - 1) / every);
    EXPECT_NE(f.at("updates").find(" solved, "), std::string::npos);
    EXPECT_EQ(f.count("update split [s]"), 1u);
    EXPECT_NE(f.at("per step [ms]").find("p99"), std::string::npos);
    const double online = std::stod(f.at("final chi2"));
    const double batch = std::stod(f.at("batch optimum"));
    EXPECT_GT(batch, 0);
    EXPECT_NEAR(online, batch, 1e-6 * batch) << out.str();
  }
}

TEST_F(ReplayTest, CheckReportsTheGapToTheOptimumSoFar) {
  ReplayCommand cmd;
  cmd.input = file_;
  cmd.check = 20;
  std::ostringstream out, err;
  ASSERT_EQ(RunReplay(cmd, out, err), 0) << err.str();
  const auto f = Fields(out.str());
  ASSERT_EQ(f.count("check"), 1u) << out.str();
  // "10 batch solves, largest relative chi2 gap: G"
  const std::string check = f.at("check");
  EXPECT_EQ(check.rfind("10 batch solves", 0), 0u) << check;
  const double gap = std::stod(check.substr(check.rfind(": ") + 2));
  EXPECT_LT(gap, 1e-3);
  EXPECT_NE(out.str().find("check at step 19:"), std::string::npos) << out.str();
}

TEST_F(ReplayTest, WritesTheFinalEstimate) {
  ReplayCommand cmd;
  cmd.input = file_;
  cmd.quiet = true;
  cmd.output = (dir_ / "out.g2o").string();
  std::ostringstream out, err;
  ASSERT_EQ(RunReplay(cmd, out, err), 0) << err.str();
  const GraphFile written = ReadGraphFile(cmd.output, DefaultRegistry());
  EXPECT_EQ(written.values.size(), 200u);
  EXPECT_EQ(written.graph.size(), factors_);
  EXPECT_NEAR(written.graph.Chi2(written.values), std::stod(Fields(out.str()).at("final chi2")), 1e-6);
}

TEST_F(ReplayTest, BadUsageAndMissingFile) {
  std::ostringstream out, err;
  ReplayCommand cmd;
  cmd.input = file_;
  cmd.every = 0;
  EXPECT_EQ(RunReplay(cmd, out, err), 2);
  cmd.every = 1;
  cmd.input = (dir_ / "missing.g2o").string();
  EXPECT_EQ(RunReplay(cmd, out, err), 1);
}

TEST_F(ReplayTest, CommandLine) {
  const std::string cmd = std::string(TETHER_CLI) + " replay " + file_ + " --every 2 -q 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string out;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof(buf), p)) > 0) out.append(buf, n);
  const int status = pclose(p);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << out;
  const auto f = Fields(out);
  EXPECT_EQ(f.at("updates").substr(0, 4), "100 ");
  EXPECT_NEAR(std::stod(f.at("final chi2")), std::stod(f.at("batch optimum")), 1e-6 * std::stod(f.at("batch optimum")));
}

}  // namespace
}  // namespace tether
