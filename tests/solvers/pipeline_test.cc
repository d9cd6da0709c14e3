// The library pipeline (read, initialise, optimise, write): the errors of each stage, and its
// options. On simulated graphs: tests/frontends/pipeline_simulated_test.cc; the same result
// as `tether optimize`: tests/tools/pipeline_cli_test.cc.
#include "tether/solvers/pipeline.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/builtin.h"
#include "tether/factors/prior.h"

namespace tether {
namespace {

namespace fs = std::filesystem;

class PipelineTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tether_pipeline_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string P(const std::string& name) const { return (dir_ / name).string(); }

  fs::path dir_;
};

TEST_F(PipelineTest, BadFileIsBadInputNamingFileAndLineAndWritesNothing) {
  {
    std::ofstream f(P("bad.g2o"));
    f << "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 nan 1 0 0 1 0 1\n";
  }
  PipelineOptions o;
  o.input = P("bad.g2o");
  o.output = P("out.g2o");
  bool solved = false;
  PipelineHooks hooks;
  hooks.on_optimized = [&](const SolverSummary&) { solved = true; };
  const PipelineResult r = RunPipeline(o, DefaultRegistry(), hooks);
  EXPECT_EQ(r.status, PipelineStatus::kBadInput);
  EXPECT_EQ(r.status, PipelineStatus::kBadInput);
  EXPECT_NE(r.message.find(P("bad.g2o") + ":3"), std::string::npos) << r.message;
  EXPECT_FALSE(r.initialized);
  EXPECT_FALSE(r.optimized);
  EXPECT_FALSE(solved);
  EXPECT_FALSE(r.written);
  EXPECT_FALSE(fs::exists(P("out.g2o")));
  EXPECT_THROW(ReadProblem(o, DefaultRegistry()), ParseError);

  o.input = P("nope.g2o");
  const PipelineResult missing = RunPipeline(o, DefaultRegistry());
  EXPECT_EQ(missing.status, PipelineStatus::kBadInput);
  EXPECT_NE(missing.message.find("nope.g2o"), std::string::npos) << missing.message;
  EXPECT_FALSE(fs::exists(P("out.g2o")));
}

// A variable that no measurement reaches (only a prior, which cannot predict it, and no
// value) cannot be initialised: the error names the problem's name, the values stay as given.
TEST(PipelineStagesTest, InitialisationFailureNamesTheFile) {
  FactorGraph g;
  g.Add(std::make_unique<BetweenSE2>(0, 1, SE2d(1, 0, 0), SqrtInformation::Isotropic(3, 0.1)));
  g.Add(std::make_unique<PriorSE2>(7, SE2d(0, 0, 0), SqrtInformation::Isotropic(3, 0.1)));
  Values v;
  v.Insert(0, SE2d(0, 0, 0));
  v.Insert(1, SE2d(2, 0, 0));
  try {
    InitializeProblem(g, &v, InitMethod::kChordal, "graph.g2o");
    FAIL() << "initialised a variable nothing reaches";
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("graph.g2o: ", 0), 0u) << e.what();
  }
  EXPECT_EQ(v.At<SE2d>(1).x(), 2.0);
  EXPECT_FALSE(v.Has(7));
}

TEST(PipelineOptionsTest, DefaultsNeedOnlyAnInput) {
  PipelineOptions o;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("input"), std::string::npos) << why;
  EXPECT_FALSE(o.IsValid(nullptr));
  o.input = "graph.g2o";
  EXPECT_TRUE(o.IsValid(&why)) << why;
  EXPECT_TRUE(why.empty());
  EXPECT_EQ(o.init, InitMethod::kChordal);
  EXPECT_EQ(o.read.format, FileFormat::kAuto);
  EXPECT_EQ(o.solver.algorithm, Algorithm::kLevenbergMarquardt);
  EXPECT_TRUE(o.output.empty());
}

TEST(PipelineOptionsTest, InvalidSolverOptionsAreRefusedBeforeReading) {
  PipelineOptions o;
  o.input = "/nonexistent/graph.g2o";
  o.solver.num_threads = 0;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("num_threads"), std::string::npos) << why;
  const PipelineResult r = RunPipeline(o, DefaultRegistry());
  EXPECT_EQ(r.status, PipelineStatus::kInvalidOptions);
  EXPECT_EQ(r.status, PipelineStatus::kInvalidOptions);
  EXPECT_EQ(r.message, why);  // nothing was read: the missing file is not mentioned
  o.solver.num_threads = 1;
  o.solver.algorithm = Algorithm::kCeres;
  o.solver.linear_solver = LinearSolverType::kQR;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("cholmod"), std::string::npos) << why;
}

TEST(PipelineOptionsTest, GncAndSwitchableAreRefusedTogetherAndCheckedAlone) {
  PipelineOptions o;
  o.input = "/nonexistent/graph.g2o";
  o.gnc = true;
  o.switchable = true;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("choose one"), std::string::npos) << why;
  o.gnc = false;
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.switchable_options.prior_sigma = -1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("switchable_options: prior_sigma"), std::string::npos) << why;
  EXPECT_EQ(RunPipeline(o, DefaultRegistry()).status, PipelineStatus::kInvalidOptions);
}

TEST(PipelineOptionsTest, StatusNamesRoundTrip) {
  for (PipelineStatus s : {PipelineStatus::kOk, PipelineStatus::kInvalidOptions, PipelineStatus::kBadInput,
                           PipelineStatus::kSolveFailed, PipelineStatus::kWriteFailed}) {
    PipelineStatus back = PipelineStatus::kOk;
    EXPECT_TRUE(FromString(ToString(s), &back)) << ToString(s);
    EXPECT_EQ(back, s);
  }
  PipelineStatus unused;
  EXPECT_FALSE(FromString("fine", &unused));
  EXPECT_STREQ(ToString(PipelineStatus::kBadInput), "bad-input");
}

}  // namespace
}  // namespace tether
