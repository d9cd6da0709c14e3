// The library pipeline on simulated graphs: the stages in order with every state kept, the
// values moved from stage to stage by default, the stages one at a time giving the whole
// pipeline's result, and an output that cannot be written. The other pipeline tests:
// tests/solvers/pipeline_test.cc, and against `tether optimize`: tests/tools/pipeline_cli_test.cc.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "testing/pipeline_fixture.h"
#include "tether/core/graph_io.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/builtin.h"
#include "tether/frontends/simulation/simulate.h"
#include "tether/solvers/covariance.h"
#include "tether/solvers/pipeline.h"

namespace tether {
namespace {

namespace fs = std::filesystem;
using testing::ReadAll;

using PipelineTest = testing::PipelineFixture;

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

// Every output the run is asked for, made by the pipeline and written together: the graph,
// the covariances, the plot; the trajectory error against the truth is in the result.
TEST_F(PipelineTest, EveryOutputWrittenTogetherWithTheTrajectoryError) {
  const SimulatedGraph sim = testing::SimulateWorld(SimWorld::kManhattan, 120, 7);
  WriteG2oFile(P("in.g2o"), sim.initial, sim.graph, DefaultRegistry());
  WriteG2oFile(P("truth.g2o"), sim.ground_truth, sim.graph, DefaultRegistry());
  PipelineOptions o;
  o.input = P("in.g2o");
  o.output = P("out.g2o");
  o.covariance = true;
  o.covariance_keys = {5, 17};
  o.plot_output = P("plot.svg");
  o.ground_truth = P("truth.g2o");
  const PipelineResult r = RunPipeline(o, DefaultRegistry());
  ASSERT_TRUE(r.ok()) << r.message;
  ASSERT_EQ(r.written_paths, (std::vector<std::string>{P("out.g2o"), P("out.g2o.cov"), P("plot.svg")}));
  EXPECT_TRUE(r.written);
  // The graph as the stage-by-stage writer gives it.
  std::ostringstream graph;
  WriteG2o(graph, r.values, r.file.graph, DefaultRegistry());
  EXPECT_EQ(ReadAll(P("out.g2o")), graph.str());
  // The covariances of the asked keys, in their order, as Marginals gives them.
  ASSERT_EQ(r.covariances.keys, (std::vector<Key>{5, 17}));
  const Marginals m(r.file.graph, r.values);
  EXPECT_TRUE(r.covariances.matrices[1].isApprox(m.Marginal(17), 1e-9));
  std::ostringstream cov;
  WriteCovariances(cov, r.values, r.covariances.keys, r.covariances.matrices);
  EXPECT_EQ(ReadAll(P("out.g2o.cov")), cov.str());
  EXPECT_FALSE(r.covariances.method.empty());
  // The trajectory error: the odometry start far off, the result close to the truth.
  EXPECT_EQ(r.result_error.poses, 120);
  EXPECT_LT(r.result_error.rmse, 0.5 * r.start_error.rmse);
  EXPECT_DOUBLE_EQ(r.result_error.rmse, AbsoluteTrajectoryError(r.values, sim.ground_truth).rmse);
  // The plot draws the truth, titled by the input.
  const std::string svg = ReadAll(P("plot.svg"));
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("ground truth"), std::string::npos);
  EXPECT_NE(svg.find("in.g2o"), std::string::npos);
}

// A stage after the solve that fails (covariances of a key no factor determines) writes none
// of the outputs: the old files stay as they were.
TEST_F(PipelineTest, AFailureAfterTheSolveReplacesNoOutput) {
  PipelineOptions o;
  o.input = Simulated("m.g2o", SimWorld::kManhattan, 60);
  o.output = P("out.g2o");
  o.plot_output = P("plot.svg");
  o.covariance = true;
  o.covariance_keys = {3, 100000};  // no such variable
  std::ofstream(P("out.g2o")) << "old graph\n";
  std::ofstream(P("plot.svg")) << "old plot\n";
  const PipelineResult r = RunPipeline(o, DefaultRegistry());
  EXPECT_EQ(r.status, PipelineStatus::kBadInput);
  EXPECT_TRUE(r.optimized);
  EXPECT_NE(r.message.find("covariance: "), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("100000"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("nothing was written"), std::string::npos) << r.message;
  EXPECT_FALSE(r.written);
  EXPECT_TRUE(r.written_paths.empty());
  EXPECT_EQ(ReadAll(P("out.g2o")), "old graph\n");
  EXPECT_EQ(ReadAll(P("plot.svg")), "old plot\n");
  EXPECT_FALSE(fs::exists(P("out.g2o.cov")));
}

// Every output is checked before the input is read, the plot's as the graph's; a plot that
// names the ground truth is refused as an output naming an input.
TEST_F(PipelineTest, EveryOutputIsCheckedBeforeReading) {
  PipelineOptions o;
  o.input = Simulated("m.g2o", SimWorld::kManhattan, 40);
  o.output = P("out.g2o");
  o.plot_output = P("no/such/folder/plot.svg");
  const PipelineResult r = RunPipeline(o, DefaultRegistry());
  EXPECT_EQ(r.status, PipelineStatus::kWriteFailed);
  EXPECT_FALSE(r.optimized);
  EXPECT_NE(r.message.find("plot.svg"), std::string::npos) << r.message;
  EXPECT_FALSE(fs::exists(P("out.g2o")));
  o.ground_truth = Simulated("t.g2o", SimWorld::kManhattan, 40);
  o.plot_output = o.ground_truth;
  const PipelineResult same = RunPipeline(o, DefaultRegistry());
  EXPECT_EQ(same.status, PipelineStatus::kInvalidOptions);
  EXPECT_NE(same.message.find("ground truth"), std::string::npos) << same.message;
}

// With GNC the rejected closures go to OUTPUT.rejected.g2o by default, each after its index
// and weight, readable as g2o lines.
TEST_F(PipelineTest, RejectedClosuresBesideTheOutput) {
  SimulatedGraph sim = testing::SimulateWorld(SimWorld::kManhattan, 150, 7);
  // Two wrong closures.
  sim.graph.Add<BetweenSE2>(Key(10), Key(120), SE2d(3, -4, 1), SqrtInformation::Isotropic(3, 0.1));
  sim.graph.Add<BetweenSE2>(Key(30), Key(140), SE2d(-2, 5, -1), SqrtInformation::Isotropic(3, 0.1));
  WriteG2oFile(P("in.g2o"), sim.initial, sim.graph, DefaultRegistry());
  PipelineOptions o;
  o.input = P("in.g2o");
  o.output = P("out.g2o");
  o.gnc = true;
  const PipelineResult r = RunPipeline(o, DefaultRegistry());
  ASSERT_TRUE(r.ok()) << r.message;
  ASSERT_EQ(r.written_paths, (std::vector<std::string>{P("out.g2o"), P("out.g2o.rejected.g2o")}));
  ASSERT_GE(r.gnc.rejected.size(), 2u);
  const std::string text = ReadAll(P("out.g2o.rejected.g2o"));
  EXPECT_EQ(text, RejectedClosuresText(r.file.graph, r.gnc.rejected, r.gnc.weights, DefaultRegistry()));
  EXPECT_NE(text.find("# factor " + std::to_string(r.gnc.rejected[0]) + ", weight"), std::string::npos) << text;
  EXPECT_NE(text.find("EDGE_SE2 10 120 3 -4 1"), std::string::npos) << text;
}

TEST(PipelineOutputOptionsTest, RulesBetweenTheOutputsAreCheckedOnce) {
  PipelineOptions o;
  o.input = "x.g2o";
  std::string why;
  o.rejected_output = "r.g2o";
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("rejected_output needs gnc or switchable"), std::string::npos) << why;
  o.switchable = true;
  EXPECT_TRUE(o.IsValid(&why)) << why;
  EXPECT_EQ(o.RejectedPath(), "r.g2o");
  o = PipelineOptions();
  o.input = "x.g2o";
  o.covariance = true;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("covariance needs a file"), std::string::npos) << why;
  o.output = "y.g2o";
  EXPECT_TRUE(o.IsValid(&why)) << why;
  EXPECT_EQ(o.CovariancePath(), "y.g2o.cov");
  o.covariance = false;
  o.covariance_keys = {1};
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("need covariance"), std::string::npos) << why;
  o = PipelineOptions();
  o.input = "x.g2o";
  o.plot.width_px = 10;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why.rfind("PipelineOptions.plot: ", 0), 0u) << why;
}

}  // namespace
}  // namespace tether
