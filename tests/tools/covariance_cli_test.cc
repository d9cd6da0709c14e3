// tether optimize --covariance: the file's format, its numbers against Marginals on the
// written result, listed ids, and the errors (an id without a covariance, an id that is not one).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "testing/cli.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/solvers/covariance.h"

namespace tether {
namespace {

namespace fs = std::filesystem;

using tether::testing::CliRun;
using tether::testing::Tether;

struct CovLine {
  Key id;
  std::string type;
  int n;
  std::vector<double> upper;
};

std::vector<CovLine> ReadCov(const std::string& path) {
  std::ifstream in(path);
  std::vector<CovLine> lines;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    CovLine c;
    s >> c.id >> c.type >> c.n;
    double x;
    while (s >> x) c.upper.push_back(x);
    lines.push_back(c);
  }
  return lines;
}

class CovarianceCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tether_cov_cli_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    const CliRun sim = Tether("simulate manhattan --poses 80 --seed 4 -o " + P("m.g2o"));
    ASSERT_EQ(sim.code, 0) << sim.output;
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string P(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

TEST_F(CovarianceCliTest, AllWritesEveryFreeVariableAsTheLibraryComputesIt) {
  const CliRun r = Tether("optimize " + P("m.g2o") + " -o " + P("out.g2o") + " --quiet --covariance all");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("wrote " + P("out.g2o.cov")), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("covariance method: CHOLMOD"), std::string::npos) << r.output;
  std::ifstream in(P("out.g2o.cov"));
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header.rfind("# tether marginal covariances", 0), 0u) << header;
  const std::vector<CovLine> lines = ReadCov(P("out.g2o.cov"));

  // The library on the written result (its values rounded by the g2o writer: close, not equal).
  const GraphFile f = ReadGraphFile(P("out.g2o"), DefaultRegistry());
  const Marginals m(f.graph, f.values);
  ASSERT_EQ(lines.size(), m.free_keys().size());
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const CovLine& c = lines[i];
    EXPECT_EQ(c.id, m.free_keys()[i]);
    EXPECT_EQ(c.type, std::string(ToString(f.values.TypeOf(c.id))));
    ASSERT_EQ(c.n, TangentDim(f.values.TypeOf(c.id)));
    ASSERT_EQ(c.upper.size(), static_cast<std::size_t>(c.n * (c.n + 1) / 2));
    const Eigen::MatrixXd want = m.Marginal(c.id);
    for (int a = 0, k = 0; a < c.n; ++a) {
      for (int b = a; b < c.n; ++b, ++k) EXPECT_NEAR(c.upper[k], want(a, b), 1e-5 * want.norm()) << c.id;
    }
  }
  EXPECT_EQ(f.values.Has(0) && m.gauge_fixed_automatically() && m.gauge_key() == 0, true);
}

TEST_F(CovarianceCliTest, ListedIdsGoToTheNamedFile) {
  const CliRun r = Tether("optimize " + P("m.g2o") + " -o " + P("out.g2o") +
                          " --quiet --linear qr --covariance 7,3 --covariance-out " + P("c.txt"));
  ASSERT_EQ(r.code, 0) << r.output;
  const std::vector<CovLine> lines = ReadCov(P("c.txt"));
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0].id, 7u);
  EXPECT_EQ(lines[1].id, 3u);
  EXPECT_EQ(lines[0].type, "SE2");
  EXPECT_FALSE(fs::exists(P("out.g2o.cov")));
}

TEST_F(CovarianceCliTest, AnIdWithoutCovarianceExitsOneAndWritesNothing) {
  CliRun r = Tether("optimize " + P("m.g2o") + " -o " + P("out.g2o") + " --quiet --covariance 3,99999");
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("variable 99999 is not in the values"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(P("out.g2o.cov")));
  r = Tether("optimize " + P("m.g2o") + " -o " + P("out.g2o") + " --quiet --covariance 0");
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("variable 0 is held fixed to remove the gauge freedom"), std::string::npos) << r.output;
}

TEST_F(CovarianceCliTest, NotAnIdIsABadOption) {
  CliRun r = Tether("optimize " + P("m.g2o") + " -o " + P("out.g2o") + " --covariance 3,x");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("'x' is not an id"), std::string::npos) << r.output;
  r = Tether("optimize " + P("m.g2o") + " --covariance all");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(
      r.output.find("covariance (--covariance) needs a file: covariance_output (--covariance-out), or output (-o)"),
      std::string::npos)
      << r.output;
}

}  // namespace
}  // namespace tether
