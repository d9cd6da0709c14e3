// tether replay on a small simulated Manhattan world: the exit codes, the printed fields, the
// final chi2 against the batch optimum, --every, --check, -o, --plot, the peak memory line and
// the library call ReplayFile.
#include "tether/tools/replay.h"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
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

  // `tether replay FILE -q ARGS`: its output (stdout and stderr); the exit code is expected to
  // be want_exit.
  std::string Run(const std::string& args, int want_exit = 0) const {
    const std::string cmd = std::string(TETHER_CLI) + " replay " + file_ + " -q " + args + " 2>&1";
    FILE* p = popen(cmd.c_str(), "r");
    EXPECT_NE(p, nullptr);
    std::string out;
    char buf[4096];
    std::size_t n;
    while (p != nullptr && (n = fread(buf, 1, sizeof(buf), p)) > 0) out.append(buf, n);
    const int status = p != nullptr ? pclose(p) : -1;
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == want_exit) << out;
    return out;
  }

  fs::path dir_;
  std::string file_;
  std::size_t factors_ = 0;
};

TEST_F(ReplayTest, FinalChi2IsTheBatchOptimum) {
  for (int every : {1, 7}) {
    ReplayCommand cmd;
    cmd.input = file_;
    cmd.options.every = every;
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
  cmd.options.check = 20;
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
  cmd.options.output = (dir_ / "out.g2o").string();
  std::ostringstream out, err;
  ASSERT_EQ(RunReplay(cmd, out, err), 0) << err.str();
  const GraphFile written = ReadGraphFile(cmd.options.output, DefaultRegistry());
  EXPECT_EQ(written.values.size(), 200u);
  EXPECT_EQ(written.graph.size(), factors_);
  EXPECT_NEAR(written.graph.Chi2(written.values), std::stod(Fields(out.str()).at("final chi2")), 1e-6);
}

TEST_F(ReplayTest, PlotsOneVertexPerUpdate) {
  ReplayCommand cmd;
  cmd.input = file_;
  cmd.options.every = 3;
  cmd.quiet = true;
  cmd.plot = (dir_ / "latency.svg").string();
  std::ostringstream out, err;
  ASSERT_EQ(RunReplay(cmd, out, err), 0) << err.str();
  EXPECT_NE(out.str().find("wrote " + cmd.plot), std::string::npos) << out.str();
  std::ifstream in(cmd.plot);
  const std::string svg((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(svg.size(), 20u);
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_EQ(svg.substr(svg.size() - 7), "</svg>\n");
  EXPECT_NE(svg.find("manhattan.g2o"), std::string::npos);  // the title names the file
  // The latencies' path: a command letter starts it, and each of the 67 updates (200 steps,
  // every 3rd and the last) adds one coordinate pair.
  const std::size_t at = svg.find("<path class=\"latencies\"");
  ASSERT_NE(at, std::string::npos);
  const std::size_t d = svg.find(" d=\"", at) + 4;
  const std::string data = svg.substr(d, svg.find('"', d) - d);
  std::size_t numbers = 0;
  for (std::size_t i = 0; i < data.size();) {
    if (data[i] == '-' || std::isdigit(static_cast<unsigned char>(data[i]))) {
      ++numbers;
      i += data[i] == '-' ? 1 : 0;
      while (i < data.size() && (std::isdigit(static_cast<unsigned char>(data[i])) || data[i] == '.')) ++i;
    } else {
      ++i;
    }
  }
  EXPECT_EQ(numbers, 2u * 67u);
  EXPECT_EQ(std::stoi(Fields(out.str()).at("updates")), 67);
}

TEST_F(ReplayTest, PrintsPeakMemory) {
  ReplayCommand cmd;
  cmd.input = file_;
  cmd.quiet = true;
  std::ostringstream out, err;
  ASSERT_EQ(RunReplay(cmd, out, err), 0) << err.str();
  const auto f = Fields(out.str());
  ASSERT_EQ(f.count("peak memory [MiB]"), 1u) << out.str();
  const double mib = std::stod(f.at("peak memory [MiB]"));
  EXPECT_GT(mib, 0);
  EXPECT_LT(mib, 1e6);
}

TEST_F(ReplayTest, LibraryCallReturnsTheMeasurements) {
  ReplayOptions o;
  o.check = 50;
  int seen = 0;
  const ReplayResult r = ReplayFile(file_, o, [&seen](const ReplayCheck&) { ++seen; });
  ASSERT_EQ(r.status, ReplayStatus::kDone) << r.message;
  EXPECT_EQ(r.poses, 200u);
  EXPECT_EQ(r.factors, factors_);
  ASSERT_EQ(r.latencies.size(), 200u);
  ASSERT_EQ(r.update_steps.size(), 200u);
  EXPECT_EQ(r.update_steps.back(), 199u);
  ASSERT_EQ(r.checks.size(), 4u);
  EXPECT_EQ(seen, 4);
  for (const ReplayCheck& c : r.checks) {
    EXPECT_GT(c.online_chi2, 0);
    EXPECT_LE(c.gap, 1e-3);
    EXPECT_LE(c.gap, r.max_check_gap);
  }
  EXPECT_EQ(r.checks[0].step, 49u);
  EXPECT_LE(r.mean_seconds, r.p99_seconds);
  EXPECT_LE(r.p99_seconds, r.max_seconds);
  EXPECT_NEAR(r.final_chi2, r.batch_chi2, 1e-6 * r.batch_chi2);
  EXPECT_GT(r.peak_rss_mib, 0);

  o.every = 0;
  EXPECT_EQ(ReplayFile(file_, o).status, ReplayStatus::kBadUsage);
  EXPECT_EQ(ReplayFile((dir_ / "missing.g2o").string(), ReplayOptions()).status, ReplayStatus::kBadInput);
}

TEST_F(ReplayTest, BadUsageAndMissingFile) {
  std::ostringstream out, err;
  ReplayCommand cmd;
  cmd.input = file_;
  cmd.options.every = 0;
  EXPECT_EQ(RunReplay(cmd, out, err), 2);
  cmd.options.every = 1;
  cmd.input = (dir_ / "missing.g2o").string();
  EXPECT_EQ(RunReplay(cmd, out, err), 1);
}

TEST_F(ReplayTest, CommandLine) {
  const std::string plot = (dir_ / "cli.svg").string();
  const std::string cmd = std::string(TETHER_CLI) + " replay " + file_ + " --every 2 -q --plot " + plot + " 2>&1";
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
  EXPECT_GT(std::stod(f.at("peak memory [MiB]")), 0);
  std::ifstream svg(plot);
  const std::string text((std::istreambuf_iterator<char>(svg)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text.rfind("<svg", 0), 0u);
  EXPECT_NE(text.find("class=\"latencies\""), std::string::npos);
  EXPECT_NEAR(std::stod(f.at("final chi2")), std::stod(f.at("batch optimum")), 1e-6 * std::stod(f.at("batch optimum")));
}

TEST_F(ReplayTest, TimesTheNewestMarginalOnRequest) {
  ReplayOptions o;
  o.time_marginal = true;
  const ReplayResult r = ReplayFile(file_, o);
  ASSERT_EQ(r.status, ReplayStatus::kDone) << r.message;
  EXPECT_EQ(r.marginals, 199u);  // every pose but the gauge
  EXPECT_GT(r.marginal_seconds, 0);
  EXPECT_GE(r.marginal_max_seconds, r.marginal_seconds / 199);
  std::ostringstream out, err;
  ReplayCommand cmd;
  cmd.input = file_;
  cmd.quiet = true;
  cmd.options.time_marginal = true;
  ASSERT_EQ(RunReplay(cmd, out, err), 0) << err.str();
  EXPECT_EQ(Fields(out.str()).count("marginal of the newest variable [ms]"), 1u) << out.str();
  // Off by default.
  const ReplayResult plain = ReplayFile(file_, ReplayOptions());
  EXPECT_EQ(plain.marginals, 0u);
}

TEST_F(ReplayTest, FixedLagFromTheCommandLine) {
  auto run = [&](const std::string& extra, int want_exit = 0) { return Run(extra, want_exit); };
  // "fixed lag: M variables marginalised, a window of at most W variables, F factor(s) left out"
  auto counts = [](const std::string& out, long* marginalised, long* window, long* left_out) {
    const auto f = Fields(out);
    ASSERT_EQ(f.count("fixed lag"), 1u) << out;
    ASSERT_EQ(
        std::sscanf(f.at("fixed lag").c_str(), "%ld variables marginalised, a window of at most %ld variables, %ld",
                    marginalised, window, left_out),
        3)
        << out;
  };
  // A lag longer than the file: nothing leaves, the result is the batch optimum.
  const std::string whole = run("--mode fixed-lag --lag 1000");
  long m = 0, w = 0, left = 0;
  counts(whole, &m, &w, &left);
  EXPECT_EQ(m, 0);
  EXPECT_EQ(w, 200);
  EXPECT_EQ(left, 0);
  const auto fw = Fields(whole);
  const std::string chi2_key = "final chi2 (the whole file at each variable's last estimate)";
  ASSERT_EQ(fw.count(chi2_key), 1u) << whole;
  EXPECT_NEAR(std::stod(fw.at(chi2_key)), std::stod(fw.at("batch optimum")), 1e-6 * std::stod(fw.at("batch optimum")));
  // A lag of 20 poses: the window stays at most 20 * 1.25 + 1, the closures that reach further
  // back are left out, and every pose's last estimate is written.
  const std::string out = (dir_ / "fixed_lag.g2o").string();
  const std::string short_lag = run("--mode fixed-lag --lag 20 -o " + out);
  counts(short_lag, &m, &w, &left);
  EXPECT_GT(m, 150);
  EXPECT_LE(w, 26);
  EXPECT_GT(left, 0);
  const GraphFile written = ReadGraphFile(out, DefaultRegistry());
  EXPECT_EQ(written.values.size(), 200u);
  EXPECT_EQ(written.graph.size(), factors_);
  // The options are checked.
  run("--mode fixed-lag --lag -1", 2);
  run("--mode fixed-lag --lag-batch -0.5", 2);
  run("--mode sliding", 2);
}

TEST_F(ReplayTest, LocalModeFromTheCommandLine) {
  // --mode local and its options reach the smoother: a region limit of 1 variable makes every
  // update with a loop closure a batch solve; the default limit leaves most of them local.
  auto run = [&](const std::string& extra, int want_exit = 0) {
    return Run("--mode local --check 25 " + extra, want_exit);
  };
  // "local mode: B batch solve(s), L local solve(s) over R variables on average"
  auto counts = [](const std::string& out, int* batch, int* local) {
    const auto f = Fields(out);
    ASSERT_EQ(f.count("local mode"), 1u) << out;
    ASSERT_EQ(std::sscanf(f.at("local mode").c_str(), "%d batch solve(s), %d local", batch, local), 2) << out;
  };
  const std::string defaults = run("");
  int batch = 0, local = 0;
  counts(defaults, &batch, &local);
  EXPECT_EQ(batch + local, 200);
  EXPECT_GT(local, 0);
  const auto f = Fields(defaults);
  EXPECT_NEAR(std::stod(f.at("final chi2")), std::stod(f.at("batch optimum")), 1e-6 * std::stod(f.at("batch optimum")));
  const std::string check = f.at("check");
  EXPECT_LT(std::stod(check.substr(check.rfind(": ") + 2)), 1e-3) << check;
  int batch1 = 0, local1 = 0;
  counts(run("--local-max-region 1"), &batch1, &local1);
  EXPECT_GT(batch1, batch);
  const std::string bad = run("--mode nonsense", 2);
  EXPECT_NE(bad.find("--mode"), std::string::npos) << bad;
}

}  // namespace
}  // namespace tether
