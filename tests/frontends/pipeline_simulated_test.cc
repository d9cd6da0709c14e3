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
#include "tether/factors/builtin.h"
#include "tether/frontends/simulation/simulate.h"
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

}  // namespace
}  // namespace tether
