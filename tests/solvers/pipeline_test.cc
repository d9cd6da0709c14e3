// The library pipeline (read, initialise, optimise, write): the same result as `tether
// optimize` (final chi2 and output bytes), errors from each stage, and its options.
#include "tether/solvers/pipeline.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/builtin.h"
#include "tether/factors/prior.h"
#include "tether/frontends/simulation/simulate.h"

namespace tether {
namespace {

namespace fs = std::filesystem;

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

struct CliRun {
  int code = -1;
  std::string output;  // stdout and stderr together
};

#ifdef TETHER_CLI
CliRun Tether(const std::string& args) {
  const std::string cmd = std::string(TETHER_CLI) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  CliRun r;
  if (p == nullptr) return r;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof(buf), p)) > 0) r.output.append(buf, n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}
#endif

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

class PipelineTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tether_pipeline_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string P(const std::string& name) const { return (dir_ / name).string(); }

  std::string Simulated(const std::string& name, SimWorld world, int poses) {
    SimulateOptions so;
    so.world = world;
    so.poses = poses;
    so.seed = 7;
    const SimulatedGraph sim = Simulate(so);
    WriteG2oFile(P(name), sim.initial, sim.graph, DefaultRegistry());
    return P(name);
  }

  // Runs the pipeline and the CLI on `input` with default options and compares them.
  void ExpectSameAsCli(const std::string& input) {
#ifndef TETHER_CLI
    GTEST_SKIP() << "the tether program is not built";
#else
    PipelineOptions o;
    o.input = input;
    o.output = P("library.g2o");
    const PipelineResult r = RunPipeline(o, DefaultRegistry());
    ASSERT_TRUE(r.ok()) << ToString(r.status) << ": " << r.message;
    EXPECT_TRUE(r.written);
    const CliRun cli = Tether("optimize -q " + input + " -o " + P("cli.g2o"));
    ASSERT_EQ(cli.code, 0) << cli.output;
    EXPECT_EQ(SummaryField(cli.output, "final chi2"), Chi2Text(r.summary.final_chi2)) << cli.output;
    EXPECT_EQ(SummaryField(cli.output, "initial chi2"), Chi2Text(r.summary.initial_chi2)) << cli.output;
    const std::string a = ReadAll(P("library.g2o")), b = ReadAll(P("cli.g2o"));
    EXPECT_FALSE(a.empty());
    EXPECT_TRUE(a == b) << "the files written by the pipeline and by `tether optimize` differ";
#endif
  }

  fs::path dir_;
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

// Each stage in turn, reported through the hooks in order; with keep_intermediate_values the
// file's start is kept apart from the initial guess and the result.
TEST_F(PipelineTest, StagesInOrderAndEveryStateKept) {
  PipelineOptions o;
  o.keep_intermediate_values = true;
  o.input = Simulated("m.g2o", SimWorld::kManhattan, 300);
  std::vector<std::string> seen;
  PipelineHooks hooks;
  hooks.on_read = [&](const GraphFile& f) { seen.push_back("read " + std::to_string(f.graph.size())); };
  hooks.on_initialized = [&](const InitSummary& s) { seen.push_back(std::string("init ") + ToString(s.method)); };
  hooks.on_optimized = [&](const SolverSummary& s) { seen.push_back(std::string("solved ") + ToString(s.status)); };
  int iterations_seen = 0;
  o.solver.callback = [&](const IterationSummary&) { ++iterations_seen; };
  const PipelineResult r = RunPipeline(o, DefaultRegistry(), hooks);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.status, PipelineStatus::kOk);
  EXPECT_TRUE(r.message.empty());
  EXPECT_FALSE(r.written);  // no output asked for
  ASSERT_EQ(seen.size(), 3u);
  EXPECT_EQ(seen[0], "read " + std::to_string(r.file.graph.size()));
  EXPECT_EQ(seen[1], "init chordal");
  EXPECT_EQ(seen[2], "solved converged");
  EXPECT_EQ(iterations_seen, static_cast<int>(r.summary.log.size()));
  EXPECT_TRUE(r.initialized);
  EXPECT_TRUE(r.optimized);
  // The file's values are the composed odometry; the chordal start is much closer to the optimum.
  const GraphFile again = ReadGraphFile(o.input, DefaultRegistry());
  EXPECT_DOUBLE_EQ(r.file.graph.Chi2(r.file.values), again.graph.Chi2(again.values));
  EXPECT_DOUBLE_EQ(r.file.graph.Chi2(r.initial), r.summary.initial_chi2);
  EXPECT_LT(r.summary.initial_chi2, r.file.graph.Chi2(r.file.values));
  EXPECT_DOUBLE_EQ(r.file.graph.Chi2(r.values), r.summary.final_chi2);
  EXPECT_LT(r.summary.final_chi2, r.summary.initial_chi2);
}

// By default the values move from stage to stage: one copy, the result's.
TEST_F(PipelineTest, WithoutKeepingTheResultIsTheOnlyCopy) {
  PipelineOptions o;
  o.input = Simulated("k.g2o", SimWorld::kManhattan, 200);
  const PipelineResult r = RunPipeline(o, DefaultRegistry());
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_TRUE(r.file.values.empty());
  EXPECT_TRUE(r.initial.empty());
  EXPECT_EQ(r.values.size(), 200u);
  EXPECT_DOUBLE_EQ(r.file.graph.Chi2(r.values), r.summary.final_chi2);
}

TEST_F(PipelineTest, TheStagesOneAtATimeGiveTheSameResult) {
  PipelineOptions o;
  o.input = Simulated("s.g2o", SimWorld::kSphere, 150);
  o.init = InitMethod::kSpanningTree;
  const PipelineResult whole = RunPipeline(o, DefaultRegistry());
  ASSERT_TRUE(whole.ok()) << whole.message;
  GraphFile f = ReadProblem(o, DefaultRegistry());
  const InitSummary is = InitializeProblem(f.graph, &f.values, o.init, o.input);
  EXPECT_EQ(is.method, InitMethod::kSpanningTree);
  const SolverSummary s = OptimizeProblem(f.graph, &f.values, o.solver);
  EXPECT_EQ(s.final_chi2, whole.summary.final_chi2);
  WriteProblem(P("stages.g2o"), f.graph, f.values, DefaultRegistry());
  std::ostringstream expected;
  WriteG2o(expected, whole.values, whole.file.graph, DefaultRegistry());
  EXPECT_EQ(ReadAll(P("stages.g2o")), expected.str());
}

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
#ifdef TETHER_CLI
  const CliRun cli = Tether("optimize -q --init file " + o.input + " -o " + P("cli.g2o"));
  EXPECT_EQ(cli.code, 3) << cli.output;
  EXPECT_NE(cli.output.find("error: " + r.message), std::string::npos) << cli.output;
  EXPECT_FALSE(fs::exists(P("cli.g2o")));
#endif
}

TEST_F(PipelineTest, OutputThatCannotBeWrittenIsWriteFailed) {
  PipelineOptions o;
  o.input = Simulated("m.g2o", SimWorld::kManhattan, 50);
  o.output = P("no/such/folder/out.g2o");
  const PipelineResult r = RunPipeline(o, DefaultRegistry());
  EXPECT_EQ(r.status, PipelineStatus::kWriteFailed);
  EXPECT_EQ(r.status, PipelineStatus::kWriteFailed);
  // Checked before anything is read: a typo in the folder costs no solve.
  EXPECT_FALSE(r.optimized);
  EXPECT_EQ(r.file.graph.size(), 0u);
  EXPECT_NE(r.message.find("no/such/folder/out.g2o"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("nothing was read"), std::string::npos) << r.message;
  EXPECT_FALSE(r.written);
  // An output that names the input is refused as an invalid option.
  o.output = o.input;
  const PipelineResult same = RunPipeline(o, DefaultRegistry());
  EXPECT_EQ(same.status, PipelineStatus::kInvalidOptions);
  EXPECT_NE(same.message.find("does not write over what it reads"), std::string::npos) << same.message;
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
