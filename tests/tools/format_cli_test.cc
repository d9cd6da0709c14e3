// tether optimize --format and --isam-noise: iSAM landmark files from the command line.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "testing/cli.h"

namespace tether {
namespace {

namespace fs = std::filesystem;

class FormatCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tether_format_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    // Three poses and one landmark, iSAM's text (square-root information, upper triangle).
    std::ofstream(dir_ / "small.txt") << "ODOMETRY 0 1 1.0 0.02 0.01 10 0 0 10 0 20\n"
                                         "ODOMETRY 1 2 1.1 -0.01 0.02 10 0 0 10 0 20\n"
                                         "LANDMARK 0 0 2.0 1.0 5 0 5\n"
                                         "LANDMARK 1 0 1.05 0.9 5 0 5\n"
                                         "LANDMARK 2 0 0.1 1.1 5 0 5\n";
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const char* name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

// The summary's "final chi2" line.
double FinalChi2(const std::string& output) {
  const auto at = output.find("final chi2");
  return at == std::string::npos ? -1.0 : std::stod(output.substr(at + 10));
}

TEST_F(FormatCliTest, IsamFilesByOptionAndTheirNoiseReading) {
  const auto sqrt_info = testing::Tether("optimize " + Path("small.txt") + " --format isam -q -o " + Path("a.g2o"));
  ASSERT_EQ(sqrt_info.code, 0) << sqrt_info.output;
  const auto cov = testing::Tether("optimize " + Path("small.txt") + " --format isam --isam-noise covariance -q -o " +
                                   Path("b.g2o"));
  ASSERT_EQ(cov.code, 0) << cov.output;
  // The same residuals weighted by R^T R (R = 10, 20, 5) or by the inverse of those numbers as a
  // covariance: two different chi2.
  const double a = FinalChi2(sqrt_info.output), b = FinalChi2(cov.output);
  ASSERT_GT(a, 0) << sqrt_info.output;
  ASSERT_GT(b, 0) << cov.output;
  EXPECT_GT(a / b, 100.0) << sqrt_info.output << cov.output;
  // The written graph reads back as g2o (landmark keys below 2^31).
  EXPECT_EQ(testing::Tether("optimize " + Path("a.g2o") + " --format g2o -q").code, 0);
  // Read as g2o, an ODOMETRY line is an unknown tag: bad input, named by file and line.
  const auto g2o = testing::Tether("optimize " + Path("small.txt") + " --format g2o -q");
  EXPECT_EQ(g2o.code, 1) << g2o.output;
  EXPECT_NE(g2o.output.find("small.txt:1"), std::string::npos) << g2o.output;
  // Unknown option values are usage errors.
  EXPECT_EQ(testing::Tether("optimize " + Path("small.txt") + " --format csv").code, 2);
  EXPECT_EQ(testing::Tether("optimize " + Path("small.txt") + " --isam-noise variance").code, 2);
}

}  // namespace
}  // namespace tether
