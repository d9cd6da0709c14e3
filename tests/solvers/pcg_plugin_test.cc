// Linear solvers from plugins: the example plugin pcg (plugins/examples/pcg) registers a
// preconditioned conjugate-gradient solver that reaches the optimum CHOLMOD reaches on the
// public files; a plugin that claims a built-in solver's name registers nothing.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "tether/core/graph_io.h"
#include "tether/core/linear_solver.h"
#include "tether/factors/builtin.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

std::string PluginPath(const std::string& name) { return std::string(TETHER_PLUGIN_BUILD_DIR) + "/" + name + ".so"; }
std::string TestPlugin(const std::string& name) {
  return std::string(TETHER_TEST_PLUGIN_DIR) + "/test_" + name + ".so";
}
std::string DatasetPath(const std::string& name) { return std::string(TETHER_DATASETS_DIR) + "/g2o/" + name; }

// The built-in solvers are registered (tether::solvers is loaded), and pcg from the plugin.
void LoadPcg() {
  LinearSolverType t;
  ASSERT_TRUE(FromString("cholmod", &t));
  static Registry registry;
  static PluginLoader loader(registry);
  const LoadedPlugin p = loader.Load(PluginPath("pcg"));
  EXPECT_EQ(p.name, "pcg");
  EXPECT_TRUE(p.type_names.empty());
  ASSERT_EQ(p.linear_solver_names, std::vector<std::string>{"pcg"});
}

TEST(PcgPluginTest, RegistersALinearSolverByName) {
  LoadPcg();
  const LinearSolverEntry* e = DefaultLinearSolverRegistry().Find("pcg");
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->owner, "pcg");
  EXPECT_EQ(e->form, LinearSystemForm::kNormalEquations);
  EXPECT_FALSE(e->direct);
  LinearSolverType t;
  ASSERT_TRUE(FromString("pcg", &t));
  EXPECT_STREQ(ToString(t), "pcg");
  EXPECT_NE(LinearSolverNames().find("pcg"), std::string::npos);
  // A second loader (another registry of factor types) finds it registered already.
  Registry other;
  PluginLoader second(other);
  EXPECT_EQ(second.Load(PluginPath("pcg")).linear_solver_names, std::vector<std::string>{"pcg"});
}

TEST(PcgPluginTest, UnknownLinearSolverIsInvalidInput) {
  SolverOptions o;
  o.linear_solver = LinearSolverType("no_such_solver");
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("linear solver 'no_such_solver' is not registered"), std::string::npos) << why;
  EXPECT_NE(why.find("cholmod"), std::string::npos) << why;
}

TEST(PcgPluginTest, AClashWithABuiltinNameRegistersNothing) {
  LinearSolverType t;
  ASSERT_TRUE(FromString("cholmod", &t));
  Registry registry;
  RegisterBuiltinFactors(registry);
  PluginLoader loader(registry);
  try {
    loader.Load(TestPlugin("dup_linear_solver"));
    FAIL() << "the plugin claims 'cholmod' and must be refused";
  } catch (const PluginError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("'cholmod' (owner 'test_dup_linear_solver')"), std::string::npos) << m;
    EXPECT_NE(m.find("taken already by 'cholmod' (owner 'builtin')"), std::string::npos) << m;
    EXPECT_NE(m.find("nothing of it was registered"), std::string::npos) << m;
  }
  EXPECT_EQ(registry.FindByName("TestDupSolverPrior"), nullptr);
  EXPECT_EQ(DefaultLinearSolverRegistry().Find("cholmod")->owner, "builtin");
  EXPECT_TRUE(loader.loaded().empty());
}

// On intel and sphere2500 from the chordal start, LM over pcg reaches CHOLMOD's optimum.
class PcgDatasetTest : public ::testing::TestWithParam<const char*> {};

TEST_P(PcgDatasetTest, ReachesTheOptimumOfCholmod) {
  const std::string path = DatasetPath(GetParam());
  if (!std::ifstream(path).good()) {
    GTEST_SKIP() << "dataset " << path << " absent (../shared/datasets not beside the repository)";
  }
  LoadPcg();
  GraphFile f = ReadGraphFile(path, DefaultRegistry());
  Initialize(f.graph, &f.values, InitMethod::kChordal);
  Values cholmod_values = f.values;
  const SolverSummary c = Optimize(f.graph, &cholmod_values, {});
  SolverOptions o;
  o.linear_solver = LinearSolverType("pcg");
  const SolverSummary p = Optimize(f.graph, &f.values, o);
  ASSERT_EQ(p.status, SolverStatus::kConverged) << p.FullReport();
  EXPECT_NEAR(p.final_chi2, c.final_chi2, 1e-6 * c.final_chi2) << p.FullReport();
  EXPECT_GT(p.linear_solver_iterations, 0);
  EXPECT_EQ(c.linear_solver_iterations, 0);
  EXPECT_NE(p.FullReport().find("lm / pcg"), std::string::npos) << p.FullReport();
  EXPECT_NE(p.FullReport().find("linear-solver iterations"), std::string::npos) << p.FullReport();
}

INSTANTIATE_TEST_SUITE_P(G2o, PcgDatasetTest, ::testing::Values("intel.g2o", "sphere2500.g2o"),
                         [](const ::testing::TestParamInfo<const char*>& i) {
                           return std::string(i.param).substr(0, std::string(i.param).find('.'));
                         });

}  // namespace
}  // namespace tether
