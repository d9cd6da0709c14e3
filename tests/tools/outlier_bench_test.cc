// The outlier benchmark (tether/tools/outlier_bench.h) on a simulated world: the false
// closures it adds are counted and recognised; least squares is ruined by them while GNC
// rejects exactly them and ends at the optimum without them; grouped false closures come in consistent
// clusters; an unknown method is refused.
#include "tether/tools/outlier_bench.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/frontends/simulation/simulate.h"

namespace tether {
namespace {

namespace fs = std::filesystem;

std::string SimulatedFile(const std::string& name) {
  SimulateOptions o;
  o.world = SimWorld::kManhattan;
  o.poses = 300;
  o.seed = 4;
  const SimulatedGraph sim = Simulate(o);
  const std::string path = (fs::temp_directory_path() / (name + std::to_string(::getpid()) + ".g2o")).string();
  WriteG2oFile(path, sim.initial, sim.graph, DefaultRegistry());
  return path;
}

TEST(OutlierBench, LeastSquaresIsRuinedAndGncAndSwitchableConstraintsKeepTheMap) {
  const std::string path = SimulatedFile("outlier_bench_");
  OutlierBenchOptions o;
  o.files = {path};
  o.rates = {0.2};
  o.seeds = {1, 2};
  o.methods = {"none", "gnc", "sc"};
  std::ostringstream progress;
  const std::vector<OutlierBenchRow> rows = RunOutlierBench(o, progress);
  fs::remove(path);
  ASSERT_EQ(rows.size(), 3u);
  for (const OutlierBenchRow& r : rows) {
    EXPECT_EQ(r.status, "ok");
    EXPECT_EQ(r.runs, 2);
    EXPECT_EQ(r.false_closures, static_cast<int>(std::lround(0.2 * r.true_closures)));
  }
  const OutlierBenchRow& none = rows[0];
  const OutlierBenchRow& gnc = rows[1];
  EXPECT_EQ(none.method, "none");
  // Measured: least squares 6.4 m from the optimum without the false closures, GNC 3e-8 m
  // (every false closure rejected, no true one: the same inlier set, the same optimum).
  EXPECT_GT(none.ate_median, 1.0);  // metres
  EXPECT_GT(none.chi2_ratio, 10);
  EXPECT_EQ(none.recall_min, 0);  // least squares rejects nothing
  EXPECT_LT(gnc.ate_max, 1e-6);
  EXPECT_EQ(gnc.recall_min, 1);
  EXPECT_EQ(gnc.precision_min, 1);
  EXPECT_NEAR(gnc.chi2_ratio, 1, 1e-6);
  // Switchable constraints (prior from the chi2 quantile, then least squares over the kept
  // closures) also end at the optimum here (measured 2.9e-8 m, precision and recall 1).
  const OutlierBenchRow& sc = rows[2];
  EXPECT_EQ(sc.method, "sc");
  EXPECT_LT(sc.ate_max, 1e-6);
  EXPECT_EQ(sc.recall_min, 1);
  EXPECT_EQ(sc.precision_min, 1);
  const std::string table = FormatOutlierBenchMarkdown(rows);
  EXPECT_NE(table.find("| gnc |"), std::string::npos) << table;
}

// GNC on input_M3500_g2o with 30% false closures for `seeds` (random or grouped), the
// progress text in *progress; false where the dataset is absent.
bool GncOnInputM3500(const std::vector<int>& seeds, bool grouped, OutlierBenchRow* row, std::string* progress) {
  const std::string path = std::string(TETHER_DATASETS_DIR) + "/g2o/input_M3500_g2o.g2o";
  if (!fs::exists(path)) return false;
  OutlierBenchOptions o;
  o.files = {path};
  o.rates = {0.3};
  o.seeds = seeds;
  o.grouped = grouped;
  o.methods = {"gnc"};
  std::ostringstream out;
  const std::vector<OutlierBenchRow> rows = RunOutlierBench(o, out);
  EXPECT_EQ(rows.size(), 1u);
  if (rows.size() != 1) return false;
  *row = rows[0];
  *progress = out.str();
  // Every false closure rejected, no true one, and the optimum without the false closures.
  EXPECT_EQ(row->status, "ok");
  EXPECT_EQ(row->runs, static_cast<int>(seeds.size()));
  EXPECT_EQ(row->precision_min, 1);
  EXPECT_EQ(row->recall_min, 1);
  EXPECT_LT(row->ate_max, 1e-6);
  return true;
}

TEST(OutlierBench, GncFromTheChunkedStartNeedsOneStageOnInputM3500) {
  // Random false closures, seeds 1 and 4: the chunked start keeps every true closure (their
  // chi2 at most 0.018 c^2) and rejects every false one, but leaves one false closure within
  // 10 c^2 (7.2 and 2.3 c^2). Geman-McClure's mu_0 comes from the kept closures alone, so one
  // stage (mu 1) settles it; from that false closure as well, mu_0 was 14 and 4.7, 9 and 6
  // stages, each a solve of the whole graph.
  OutlierBenchRow row;
  std::string progress;
  if (!GncOnInputM3500({1, 4}, false, &row, &progress))
    GTEST_SKIP() << "input_M3500_g2o.g2o absent (../shared/datasets)";
  EXPECT_EQ(row.gnc_stages_max, 1);
  EXPECT_GT(row.gnc_start_seconds, 0);
  EXPECT_NE(progress.find("GNC over the seeds: start"), std::string::npos) << progress;
}

TEST(OutlierBench, GncHoldsAGroupedSeedOfInputM3500) {
  // Grouped false closures (clusters of 5 agreeing on one wrong relative pose), seed 4: with
  // DCS's phi at c^2 before the closures' scale is learned, one cluster got into the first
  // chunk's map (precision 0.976, recall 0.991, 0.25 m off); at 0.3 c^2 (and at 1) every false
  // closure is rejected and no true one (checked by GncOnInputM3500).
  OutlierBenchRow row;
  std::string progress;
  if (!GncOnInputM3500({4}, true, &row, &progress)) GTEST_SKIP() << "input_M3500_g2o.g2o absent (../shared/datasets)";
  EXPECT_EQ(row.mode, "grouped");
}

TEST(OutlierBench, AnUnknownMethodIsRefused) {
  OutlierBenchOptions o;
  o.files = {"unused.g2o"};
  o.methods = {"ransac"};
  std::ostringstream progress;
  EXPECT_THROW(RunOutlierBench(o, progress), InvalidArgument);
  for (const char* bad : {"sc:", "sc:0", "sc:-1", "sc:x", "sc:1x"}) {
    o.methods = {bad};
    EXPECT_THROW(RunOutlierBench(o, progress), InvalidArgument) << bad;
  }
}

}  // namespace
}  // namespace tether
