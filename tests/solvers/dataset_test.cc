// Final chi2 on the public g2o datasets (../shared/datasets/g2o) against reference values
// measured with g2o's own optimiser (Levenberg-Marquardt, CHOLMOD) from the same start.
//
// Tolerance: no higher than the reference by more than 1e-6 relative (the figure).
// g2o does not normalise the quaternions it reads, so on the 3D files its chi2 sits slightly
// below the true value of the normalised problem; where that gap exceeds 1e-6 (parking-garage)
// the reference is the best-known value of the normalised problem instead.
#include <gtest/gtest.h>

#include <fstream>
#include <ostream>

#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

struct Reference {
  const char* file;
  double initial_chi2;  // 0: edges only (spanning-tree start)
  double reference;     // g2o's converged chi2 (or best known, see above)
};

const Reference kReferences[] = {
    {"intel.g2o", 551.736, 45.004696},           {"CSAIL.g2o", 0, 40.555129},
    {"manhattan.g2o", 0, 3549.036796},           {"kitti_00.g2o", 0, 98.322012},
    {"input_M3500_g2o.g2o", 2.56667e6, 137.913}, {"sphere2500.g2o", 2.54781e6, 727.149471},
    {"parking-garage.g2o", 16720.0, 1.238691},   {"smallGrid3D.g2o", 115958, 458.153787},
    {"tinyGrid3D.g2o", 213.064, 6.727882},
};

// Test names and ctest listings show the file, not the struct's bytes.
void PrintTo(const Reference& r, std::ostream* os) { *os << r.file; }

std::string DatasetPath(const std::string& name) { return std::string(TETHER_DATASETS_DIR) + "/g2o/" + name; }

bool Exists(const std::string& path) { return std::ifstream(path).good(); }

class DatasetTest : public ::testing::TestWithParam<Reference> {};

TEST_P(DatasetTest, ReachesReferenceChi2) {
  const Reference& ref = GetParam();
  const std::string path = DatasetPath(ref.file);
  if (!Exists(path)) GTEST_SKIP() << "dataset " << path << " absent (../shared/datasets not beside the repository)";
  GraphFile f = ReadGraphFile(path, DefaultRegistry());
  if (ref.initial_chi2 > 0) {
    EXPECT_NEAR(f.graph.Chi2(f.values), ref.initial_chi2, 1e-5 * ref.initial_chi2);
  } else {
    EXPECT_GT(f.initialised_by_spanning_tree, 0);
  }
  // Levenberg-Marquardt (the default) and dog-leg, each from the file's start.
  for (const Algorithm& algorithm : {Algorithm::kLevenbergMarquardt, Algorithm::kDogLeg}) {
    SCOPED_TRACE(ToString(algorithm));
    Values values = f.values;
    SolverOptions o;
    o.algorithm = algorithm;
    const SolverSummary s = Optimize(f.graph, &values, o);
    EXPECT_EQ(s.status, SolverStatus::kConverged) << s.FullReport();
    EXPECT_LE(s.final_chi2, ref.reference * (1 + 1e-6)) << s.FullReport();
    EXPECT_NEAR(s.final_chi2, f.graph.Chi2(values), 1e-9 * s.final_chi2);
  }
}

INSTANTIATE_TEST_SUITE_P(G2o, DatasetTest, ::testing::ValuesIn(kReferences),
                         [](const ::testing::TestParamInfo<Reference>& i) {
                           std::string n = i.param.file;
                           n = n.substr(0, n.find('.'));
                           for (char& c : n)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return n;
                         });

// From the chordal initial guess with default options (LM), every file reaches the best-known
// optimum (the table: LM started from a certified global optimum) to 1e-6 relative,
// MIT and ais2klinik included, where the files' own starts lead to local minima or crawl.
// input_M3500 has no best-known figure; g2o's converged value stands in.
struct BestKnown {
  const char* file;
  double chi2;
};

const BestKnown kBestKnown[] = {
    {"intel.g2o", 45.004696},         {"MIT.g2o", 41.163269},         {"CSAIL.g2o", 40.555129},
    {"manhattan.g2o", 3549.036796},   {"ais2klinik.g2o", 172.815579}, {"kitti_00.g2o", 98.322012},
    {"input_M3500_g2o.g2o", 137.913}, {"sphere2500.g2o", 727.149667}, {"parking-garage.g2o", 1.238691},
    {"smallGrid3D.g2o", 458.153784},  {"tinyGrid3D.g2o", 6.727882},
};

void PrintTo(const BestKnown& r, std::ostream* os) { *os << r.file; }

class ChordalDatasetTest : public ::testing::TestWithParam<BestKnown> {};

TEST_P(ChordalDatasetTest, ReachesBestKnownChi2) {
  const BestKnown& ref = GetParam();
  const std::string path = DatasetPath(ref.file);
  if (!Exists(path)) GTEST_SKIP() << "dataset " << path << " absent (../shared/datasets not beside the repository)";
  GraphFile f = ReadGraphFile(path, DefaultRegistry());
  Initialize(f.graph, &f.values, InitMethod::kChordal);
  Values lm_values = f.values;
  const SolverSummary s = Optimize(f.graph, &lm_values, {});
  EXPECT_EQ(s.status, SolverStatus::kConverged) << s.FullReport();
  // The best-known values are printed to 6 decimals: allow their rounding, 5e-7 absolute.
  EXPECT_NEAR(s.final_chi2, ref.chi2, 1e-6 * ref.chi2 + 5e-7) << s.FullReport();
  // Dog-leg from the same start reaches the same optimum as LM, to 1e-6 relative.
  SolverOptions dogleg;
  dogleg.algorithm = Algorithm::kDogLeg;
  const SolverSummary d = Optimize(f.graph, &f.values, dogleg);
  EXPECT_EQ(d.status, SolverStatus::kConverged) << d.FullReport();
  EXPECT_NEAR(d.final_chi2, s.final_chi2, 1e-6 * s.final_chi2) << d.FullReport();
}

INSTANTIATE_TEST_SUITE_P(G2o, ChordalDatasetTest, ::testing::ValuesIn(kBestKnown),
                         [](const ::testing::TestParamInfo<BestKnown>& i) {
                           std::string n = i.param.file;
                           n = n.substr(0, n.find('.'));
                           for (char& c : n)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return n;
                         });

// Where g2o does not converge (ais2klinik: 18842.48 after 100 iterations; MIT: stuck at
// 526.33), tether must at least not do worse within the same 100 iterations on ais2klinik,
// and Gauss-Newton reaches the best-known optimum (172.815579).
TEST(DatasetTest, Ais2klinikBeatsG2oWithinHundredIterations) {
  const std::string path = DatasetPath("ais2klinik.g2o");
  if (!Exists(path)) GTEST_SKIP() << "dataset " << path << " absent";
  GraphFile f = ReadGraphFile(path, DefaultRegistry());
  EXPECT_NEAR(f.graph.Chi2(f.values), 1.29739e6, 1e-5 * 1.29739e6);
  Values lm_values = f.values;
  const SolverSummary lm = Optimize(f.graph, &lm_values, {});
  EXPECT_LT(lm.final_chi2, 18842.48);
  SolverOptions gn;
  gn.algorithm = Algorithm::kGaussNewton;
  const SolverSummary s = Optimize(f.graph, &f.values, gn);
  EXPECT_EQ(s.status, SolverStatus::kConverged);
  EXPECT_LE(s.final_chi2, 172.815579 * (1 + 1e-6));
}

TEST(DatasetTest, MitLowersChi2AndStaysFinite) {
  const std::string path = DatasetPath("MIT.g2o");
  if (!Exists(path)) GTEST_SKIP() << "dataset " << path << " absent";
  GraphFile f = ReadGraphFile(path, DefaultRegistry());
  EXPECT_NEAR(f.graph.Chi2(f.values), 4.41418e9, 1e-5 * 4.41418e9);
  const SolverSummary s = Optimize(f.graph, &f.values, {});
  EXPECT_TRUE(s.IsSolutionUsable());
  EXPECT_LT(s.final_chi2, 1000.0);  // from 4.4e9; the global optimum (41.16) needs a better start
  EXPECT_NEAR(s.final_chi2, f.graph.Chi2(f.values), 1e-9 * s.final_chi2);
}

}  // namespace
}  // namespace tether
