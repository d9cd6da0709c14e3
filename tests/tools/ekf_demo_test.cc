// tether ekf-demo: the table, the picture, usage errors and outputs that cannot be written.
#include "tether/tools/ekf_demo.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "testing/cli.h"

namespace tether {
namespace {

namespace fs = std::filesystem;

std::string Slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

const EkfDemoRow* Row(const EkfDemoConfig& c, const std::string& method) {
  for (const EkfDemoRow& r : c.rows) {
    if (r.method == method) return &r;
  }
  return nullptr;
}

double Mean(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m += x / static_cast<double>(v.size());
  return m;
}

// The figures over a few seeds: every method ran on every seed, the filters and the graph are
// far closer to the truth than dead reckoning, known association makes no wrong association,
// and the graphs seeded by EKF and UKF end at the same optimum.
TEST(EkfDemoTest, KnownAssociationFigures) {
  const EkfDemoConfig c = RunEkfExperiment(1, false, 3, 1, EkfDemoSetup{60, 2.0, 0.17453292519943295});
  for (const char* m :
       {"dead reckoning", "EKF", "UKF", "invariant EKF", "FastSLAM 1.0 (100 particles)", "FastSLAM 2.0 (100 particles)",
        "graph (EKF seed)", "graph (UKF seed)", "graph (dead reckoning seed)"}) {
    const EkfDemoRow* r = Row(c, m);
    ASSERT_NE(r, nullptr) << m;
    EXPECT_EQ(r->trajectory_rmse.size(), 3u) << m;
    EXPECT_EQ(r->failures, 0) << m << ": " << r->failure_note;
    EXPECT_EQ(Mean(r->wrong_associations), 0.0) << m;
  }
  const double dr = Mean(Row(c, "dead reckoning")->trajectory_rmse);
  for (const char* m : {"EKF", "UKF", "invariant EKF", "FastSLAM 1.0 (100 particles)", "FastSLAM 2.0 (100 particles)",
                        "graph (EKF seed)"})
    EXPECT_LT(Mean(Row(c, m)->trajectory_rmse), 0.5 * dr) << m;
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(Row(c, "graph (EKF seed)")->trajectory_rmse[k], Row(c, "graph (UKF seed)")->trajectory_rmse[k], 1e-4);
    // FastSLAM's known associations are the same: the same optimum from its seed.
    ASSERT_NE(Row(c, "graph (FastSLAM 2.0 seed)"), nullptr);
    EXPECT_NEAR(Row(c, "graph (EKF seed)")->trajectory_rmse[k], Row(c, "graph (FastSLAM 2.0 seed)")->trajectory_rmse[k],
                1e-4);
  }
}

TEST(EkfDemoTest, NearestNeighbourCountsWrongAssociations) {
  const EkfDemoConfig c = RunEkfExperiment(1, true, 2, 1, EkfDemoSetup{40, 2.0, 0.17453292519943295});
  EXPECT_EQ(Row(c, "graph (dead reckoning seed)"), nullptr);  // dead reckoning associates nothing
  ASSERT_NE(Row(c, "EKF"), nullptr);
  // The thesis's landmarks lie about as far apart as the range noise: some wrong associations
  // are expected, and counted.
  EXPECT_GT(Mean(Row(c, "EKF")->wrong_associations), 0.0);
  // FastSLAM associates per particle; its row counts the heaviest particle's.
  ASSERT_NE(Row(c, "FastSLAM 2.0 (100 particles)"), nullptr);
  EXPECT_EQ(Row(c, "FastSLAM 2.0 (100 particles)")->wrong_associations.size(), 2u);
}

// --nees: every method's NEES at every step of every seed, the graph's from the smoother's
// online estimate. On 6 worlds of 80 steps at the thesis's noise the EKF is far above the 95%
// interval and the graph (EKF seed) near the consistent value 3.
TEST(EkfDemoTest, ConsistencyPerStep) {
  EkfDemoSetup setup{80, 2.0, 0.17453292519943295};
  setup.consistency = true;
  const EkfDemoConfig c = RunEkfExperiment(1, false, 6, 1000, setup);
  for (const char* method : {"EKF", "UKF", "invariant EKF", "graph (EKF seed)", "graph (UKF seed)"}) {
    const EkfDemoRow* r = Row(c, method);
    ASSERT_NE(r, nullptr) << method;
    EXPECT_EQ(r->nees_runs, 6) << method;
    ASSERT_EQ(r->step_nees.size(), 81u) << method;
  }
  EXPECT_EQ(Row(c, "dead reckoning")->nees_runs, 0);  // no covariance
  const auto average = [](const EkfDemoRow* r) {
    double m = 0;
    for (std::size_t k = 2; k < r->step_nees.size(); ++k) m += r->step_nees[k] / r->nees_runs / 79.0;
    return m;
  };
  EXPECT_GT(average(Row(c, "EKF")), 3 * 4.0);
  EXPECT_GT(average(Row(c, "invariant EKF")), 2.0);
  EXPECT_LT(average(Row(c, "invariant EKF")), 4.5);
  EXPECT_GT(average(Row(c, "graph (EKF seed)")), 2.0);
  EXPECT_LT(average(Row(c, "graph (EKF seed)")), 4.5);
  const std::string table = EkfDemoConsistencyTable({c});
  EXPECT_NE(table.find("| 1 | known | graph (EKF seed) | 6 |"), std::string::npos) << table;
  EXPECT_EQ(table.find("dead reckoning |"), std::string::npos) << table;
  // Without --nees nothing is recorded and the table is its header alone.
  const EkfDemoConfig plain = RunEkfExperiment(1, false, 1, 1, EkfDemoSetup{20, 2.0, 0.17453292519943295});
  EXPECT_EQ(Row(plain, "EKF")->nees_runs, 0);
  EXPECT_EQ(EkfDemoConsistencyTable({plain}).find("| 1 | known"), std::string::npos);
}

TEST(EkfDemoCliTest, WritesTableAndPlot) {
  const fs::path dir = fs::temp_directory_path() / ("tether_ekf_demo_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path table = dir / "table.md", plot = dir / "demo.svg";
  const auto run = testing::Tether("ekf-demo --seeds 2 --steps 30 --experiments 2 --association known --nees -o " +
                                   table.string() + " --plot " + plot.string());
  ASSERT_EQ(run.code, 0) << run.output;
  EXPECT_NE(run.output.find("| 2 | known | UKF |"), std::string::npos) << run.output;
  const std::string t = Slurp(table);
  EXPECT_NE(t.find("| 2 | known | graph (EKF seed) |"), std::string::npos) << t;
  EXPECT_NE(t.find("| 2 | known | graph (EKF seed) | 2 |"), std::string::npos) << t;  // the NEES table, 2 runs
  const std::string svg = Slurp(plot);
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  for (const char* name : {"truth", "dead reckoning", "EKF", "UKF", "invariant EKF", "graph (EKF seed)", "2 sigma",
                           "FastSLAM 2.0 (100 particles)", "particles every 50 steps"}) {
    EXPECT_NE(svg.find(name), std::string::npos) << name;
  }
  // Usage errors (exit 2) and an output in a folder that does not exist (exit 4, nothing run).
  EXPECT_EQ(testing::Tether("ekf-demo --experiments 3").code, 2);
  EXPECT_EQ(testing::Tether("ekf-demo --association maybe").code, 2);
  EXPECT_EQ(testing::Tether("ekf-demo --seeds 0").code, 2);
  EXPECT_EQ(testing::Tether("ekf-demo --invariant-iterations 0").code, 2);
  EXPECT_EQ(testing::Tether("ekf-demo --invariant-min-range inf").code, 2);
  EXPECT_EQ(testing::Tether("ekf-demo --invariant-min-range nan").code, 2);
  EXPECT_EQ(testing::Tether("ekf-demo --min-range -1").code, 2);
  EXPECT_EQ(testing::Tether("ekf-demo --fastslam 3").code, 2);
  EXPECT_EQ(testing::Tether("ekf-demo --fastslam-particles 0").code, 2);
  EXPECT_EQ(testing::Tether("ekf-demo --fastslam-particles 10,x").code, 2);
  EXPECT_EQ(testing::Tether("ekf-demo --fastslam-particles ''").code, 2);
  // FastSLAM's rows: the versions and counts asked for, or none.
  const auto fast = testing::Tether(
      "ekf-demo --seeds 1 --steps 20 --experiments 1 --association known --no-graph --fastslam 2 "
      "--fastslam-particles 5,10");
  ASSERT_EQ(fast.code, 0) << fast.output;
  EXPECT_NE(fast.output.find("| FastSLAM 2.0 (5 particles) |"), std::string::npos) << fast.output;
  EXPECT_NE(fast.output.find("| FastSLAM 2.0 (10 particles) |"), std::string::npos) << fast.output;
  EXPECT_EQ(fast.output.find("FastSLAM 1.0"), std::string::npos) << fast.output;
  const auto no_fast = testing::Tether(
      "ekf-demo --seeds 1 --steps 20 --experiments 1 --association known --no-graph "
      "--fastslam-particles none");
  ASSERT_EQ(no_fast.code, 0) << no_fast.output;
  EXPECT_EQ(no_fast.output.find("FastSLAM"), std::string::npos) << no_fast.output;
  // --no-graph: the filters alone.
  const auto filters = testing::Tether("ekf-demo --seeds 1 --steps 20 --experiments 1 --association known --no-graph");
  ASSERT_EQ(filters.code, 0) << filters.output;
  EXPECT_NE(filters.output.find("| 1 | known | invariant EKF |"), std::string::npos) << filters.output;
  EXPECT_EQ(filters.output.find("graph ("), std::string::npos) << filters.output;
  const auto missing = testing::Tether("ekf-demo --seeds 1 -o " + (dir / "no" / "t.md").string());
  EXPECT_EQ(missing.code, 4) << missing.output;
  EXPECT_EQ(missing.output.find("| experiment"), std::string::npos) << missing.output;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace tether
