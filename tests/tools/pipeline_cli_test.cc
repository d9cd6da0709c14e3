// The library pipeline gives what `tether optimize` gives: the same final chi2 and output
// bytes on a simulated graph and on intel, and the same refusal of a start whose chi2 is not
// finite. The pipeline's own tests: tests/solvers/pipeline_test.cc,
// tests/frontends/pipeline_simulated_test.cc.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "testing/cli.h"
#include "testing/pipeline_fixture.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/frontends/simulation/simulate.h"
#include "tether/solvers/pipeline.h"

namespace tether {
namespace {

namespace fs = std::filesystem;
using testing::ReadAll;

// The value the CLI's summary prints on the line starting with `what` ("  final chi2 ...").
std::string SummaryField(const std::string& report, const std::string& what) {
  const std::size_t at = report.find(what);
  if (at == std::string::npos) return "";
  const std::size_t begin = report.find_first_not_of(' ', at + what.size());
  return report.substr(begin, report.find('\n', begin) - begin);
}

std::string Chi2Text(double chi2) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.9g", chi2);
  return buf;
}

class PipelineTest : public testing::PipelineFixture {
 protected:
  // Runs the pipeline and the CLI on `input` with default options and compares them.
  void ExpectSameAsCli(const std::string& input) {
    PipelineOptions o;
    o.input = input;
    o.output = P("library.g2o");
    const PipelineResult r = RunPipeline(o, DefaultRegistry());
    ASSERT_TRUE(r.ok()) << ToString(r.status) << ": " << r.message;
    EXPECT_TRUE(r.written);
    const testing::CliRun cli = testing::Tether("optimize -q " + input + " -o " + P("cli.g2o"));
    ASSERT_EQ(cli.code, 0) << cli.output;
    EXPECT_EQ(SummaryField(cli.output, "final chi2"), Chi2Text(r.summary.final_chi2)) << cli.output;
    EXPECT_EQ(SummaryField(cli.output, "initial chi2"), Chi2Text(r.summary.initial_chi2)) << cli.output;
    const std::string a = ReadAll(P("library.g2o")), b = ReadAll(P("cli.g2o"));
    EXPECT_FALSE(a.empty());
    EXPECT_TRUE(a == b) << "the files written by the pipeline and by `tether optimize` differ";
  }
};

TEST_F(PipelineTest, GivesTheCliResultOnASimulatedGraph) {
  ExpectSameAsCli(Simulated("m.g2o", SimWorld::kManhattan, 400));
}

TEST_F(PipelineTest, GivesTheCliResultOnIntel) {
  const std::string path = std::string(TETHER_DATASETS_DIR) + "/g2o/intel.g2o";
  if (!std::ifstream(path).good()) {
    GTEST_SKIP() << "dataset " << path << " absent (../shared/datasets not beside the repository)";
  }
  ExpectSameAsCli(path);
}

// A start so far off that chi2 is not finite: the solver refuses it, nothing is written, and
// the CLI says the same.
TEST_F(PipelineTest, SolveFailureIsReportedAndNothingIsWritten) {
  {
    std::ofstream f(P("far.g2o"));
    f << "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1e200 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n";
  }
  PipelineOptions o;
  o.input = P("far.g2o");
  o.output = P("out.g2o");
  o.init = InitMethod::kFile;
  const PipelineResult r = RunPipeline(o, DefaultRegistry());
  EXPECT_EQ(r.status, PipelineStatus::kSolveFailed);
  EXPECT_EQ(r.status, PipelineStatus::kSolveFailed);
  EXPECT_TRUE(r.optimized);
  EXPECT_EQ(r.summary.status, SolverStatus::kInvalidInput);
  EXPECT_NE(r.message.find("the solve failed (invalid-input): chi2 at the initial values is not finite"),
            std::string::npos)
      << r.message;
  EXPECT_NE(r.message.find("no output written"), std::string::npos) << r.message;
  EXPECT_FALSE(r.written);
  EXPECT_FALSE(fs::exists(P("out.g2o")));
  const testing::CliRun cli = testing::Tether("optimize -q --init file " + o.input + " -o " + P("cli.g2o"));
  EXPECT_EQ(cli.code, 3) << cli.output;
  EXPECT_NE(cli.output.find("error: " + r.message), std::string::npos) << cli.output;
  EXPECT_FALSE(fs::exists(P("cli.g2o")));
}

}  // namespace
}  // namespace tether
