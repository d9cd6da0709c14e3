// The Ceres adapter against the native Levenberg-Marquardt on public g2o datasets
// (../shared/datasets/g2o): from the file's own start and from the chordal start, both reach
// the same final chi2 to 1e-6 relative (the figure).
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>

#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/solvers/ceres_adapter.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

std::string DatasetPath(const std::string& name) { return std::string(TETHER_DATASETS_DIR) + "/g2o/" + name; }

struct Case {
  const char* file;
  InitMethod init;
};

class CeresDatasetTest : public ::testing::TestWithParam<Case> {};

TEST_P(CeresDatasetTest, AgreesWithNativeLmOnFinalChi2) {
  const std::string path = DatasetPath(GetParam().file);
  if (!std::ifstream(path).good()) {
    GTEST_SKIP() << "dataset " << path << " absent (../shared/datasets not beside the repository)";
  }
  GraphFile f = ReadGraphFile(path, DefaultRegistry());
  Initialize(f.graph, &f.values, GetParam().init);
  Values native = f.values, ceres = f.values;
  const auto t0 = std::chrono::steady_clock::now();
  const SolverSummary sn = Optimize(f.graph, &native, {});
  const auto t1 = std::chrono::steady_clock::now();
  const SolverSummary sc = OptimizeWithCeres(f.graph, &ceres, {});
  const auto t2 = std::chrono::steady_clock::now();
  ASSERT_EQ(sn.status, SolverStatus::kConverged) << sn.FullReport();
  ASSERT_EQ(sc.status, SolverStatus::kConverged) << sc.FullReport();
  EXPECT_NEAR(sc.initial_chi2, sn.initial_chi2, 1e-12 * sn.initial_chi2);
  EXPECT_EQ(sc.final_chi2, f.graph.Chi2(ceres));
  EXPECT_NEAR(sc.final_chi2, sn.final_chi2, 1e-6 * sn.final_chi2) << sc.FullReport() << sn.FullReport();
  std::printf("%s (%s start): chi2 %.9g (native, %d it, %.3f s) %.9g (ceres, %d it, %.3f s), rel. diff %.2e\n",
              GetParam().file, ToString(GetParam().init), sn.final_chi2, sn.iterations,
              std::chrono::duration<double>(t1 - t0).count(), sc.final_chi2, sc.iterations,
              std::chrono::duration<double>(t2 - t1).count(), std::abs(sc.final_chi2 - sn.final_chi2) / sn.final_chi2);
}

INSTANTIATE_TEST_SUITE_P(G2o, CeresDatasetTest,
                         ::testing::Values(Case{"intel.g2o", InitMethod::kFile},
                                           Case{"intel.g2o", InitMethod::kChordal},
                                           Case{"sphere2500.g2o", InitMethod::kFile},
                                           Case{"sphere2500.g2o", InitMethod::kChordal}),
                         [](const ::testing::TestParamInfo<Case>& i) {
                           std::string n = i.param.file;
                           n = n.substr(0, n.find('.')) + "_" + ToString(i.param.init);
                           for (char& c : n)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return n;
                         });

}  // namespace
}  // namespace tether
