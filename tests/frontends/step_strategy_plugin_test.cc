// Step strategies from plugins: a test plugin adds "gn-halving" (Gauss-Newton with step
// halving) through AddStepStrategy; it is selected by name like a built-in strategy, reaches
// LM's optimum on a simulated world, and a plugin that claims a built-in strategy's name
// registers nothing. Selected on the command line: tests/tools/step_strategy_plugin_cli_test.cc.
#include <gtest/gtest.h>

#include <string>

#include "testing/simulated.h"
#include "tether/factors/builtin.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/solvers/optimizer.h"
#include "tether/solvers/step_strategy.h"

namespace tether {
namespace {

std::string TestPlugin(const std::string& name) {
  return std::string(TETHER_TEST_PLUGIN_DIR) + "/test_" + name + ".so";
}

TEST(StepStrategyPluginTest, AddsAStrategySelectedByNameThatReachesTheOptimum) {
  Registry registry;
  RegisterBuiltinFactors(registry);
  PluginLoader loader(registry);
  const LoadedPlugin p = loader.Load(TestPlugin("step_strategy"));
  EXPECT_EQ(p.extension_names, std::vector<std::string>{"step strategy 'gn-halving'"});
  EXPECT_NE(p.Summary().find("(1 factor type, step strategy 'gn-halving')"), std::string::npos) << p.Summary();
  ASSERT_TRUE(FindStepStrategy("gn-halving"));
  Algorithm a;
  ASSERT_TRUE(FromString("gn-halving", &a));
  EXPECT_NE(AlgorithmNames().find("gn-halving"), std::string::npos);

  const SimulatedGraph sim = testing::SimulateWorld(SimWorld::kManhattan, 400, 3);
  Values lm_values = sim.initial, values = sim.initial;
  const SolverSummary lm = Optimize(sim.graph, &lm_values, {});
  SolverOptions o;
  o.algorithm = a;
  const SolverSummary s = Optimize(sim.graph, &values, o);
  ASSERT_TRUE(s.IsSolutionUsable()) << s.FullReport();
  EXPECT_NEAR(s.final_chi2, lm.final_chi2, 1e-6 * lm.final_chi2) << s.FullReport();
  EXPECT_NE(s.FullReport().find("gn-halving"), std::string::npos) << s.FullReport();

  // Loading it again changes nothing, nor does a second loader with a registry of its own (the
  // strategy is the plugin's already); the name stays taken for a program's own strategy.
  EXPECT_NO_THROW(loader.Load(TestPlugin("step_strategy")));
  Registry other;
  PluginLoader second(other);
  EXPECT_NO_THROW(second.Load(TestPlugin("step_strategy")));
  EXPECT_NE(other.FindByName("TestStrategyPrior"), nullptr);
  EXPECT_THROW(RegisterStepStrategy("gn-halving", [](const SolverOptions&) { return nullptr; }), InvalidArgument);
}

TEST(StepStrategyPluginTest, APluginClaimingABuiltInStrategyRegistersNothing) {
  Registry registry;
  PluginLoader loader(registry);
  try {
    loader.Load(TestPlugin("dup_step_strategy"));
    FAIL() << "the plugin was loaded";
  } catch (const PluginError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("cannot register step strategy 'lm': the name is taken already (built in)"), std::string::npos)
        << m;
    EXPECT_NE(m.find("nothing of it was registered"), std::string::npos) << m;
  }
  EXPECT_EQ(registry.FindByName("TestDupStrategyPrior"), nullptr);  // its factor type was not kept
  EXPECT_TRUE(loader.loaded().empty());
  ASSERT_TRUE(FindStepStrategy("lm"));  // the built-in one is untouched
  EXPECT_FALSE(RemoveStepStrategy("lm"));
}

TEST(StepStrategyPluginTest, AFactoryThatMakesNothingOrThrowsIsInvalidInput) {
  RegisterStepStrategy("test-null", [](const SolverOptions&) { return std::unique_ptr<StepStrategy>(); });
  RegisterStepStrategy(
      "test-throws", [](const SolverOptions&) -> std::unique_ptr<StepStrategy> { throw InvalidArgument("not today"); });
  const SimulatedGraph sim = testing::SimulateWorld(SimWorld::kManhattan, 50, 1);
  for (const char* name : {"test-null", "test-throws"}) {
    Values v = sim.initial;
    SolverOptions o;
    ASSERT_TRUE(FromString(name, &o.algorithm));
    const SolverSummary s = Optimize(sim.graph, &v, o);
    EXPECT_EQ(s.status, SolverStatus::kInvalidInput) << name;
    EXPECT_NE(s.message.find(std::string("the step strategy '") + name + "'"), std::string::npos) << s.message;
    EXPECT_EQ(v.Data(VarType::kSE2), sim.initial.Data(VarType::kSE2));  // untouched
  }
  EXPECT_TRUE(RemoveStepStrategy("test-null"));
  EXPECT_TRUE(RemoveStepStrategy("test-throws"));
}

}  // namespace
}  // namespace tether
