// Robust loss rules (tether/core/robust_rules.h): their text form, which factors each rule
// selects (loop closures, all, a g2o tag), later rules replacing earlier ones, a tag no type
// has refused before anything changes, and a loss name looked up when the rules are applied
// where it was not registered when they were parsed (a plugin's, loaded later).
#include "tether/core/robust_rules.h"

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/robust_kernels.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/builtin.h"
#include "tether/factors/prior.h"

namespace tether {
namespace {

// Odometry 0-1, 1-2, a loop closure 0-2 (marked), and a prior on 0.
FactorGraph Graph() {
  FactorGraph g;
  const SqrtInformation unit = SqrtInformation::Identity(3);
  g.Add<BetweenSE2>(Key(0), Key(1), SE2d(1, 0, 0), unit);
  g.Add<BetweenSE2>(Key(1), Key(2), SE2d(1, 0, 0), unit);
  g.Add<BetweenSE2>(Key(0), Key(2), SE2d(2, 0, 0), unit);
  g.at(2).set_loop_closure(true);
  g.Add<PriorSE2>(Key(0), SE2d(0, 0, 0), unit);
  return g;
}

std::vector<std::string> Losses(const FactorGraph& g) {
  std::vector<std::string> names;
  for (std::size_t i = 0; i < g.size(); ++i) names.push_back(g.at(i).loss() ? g.at(i).loss()->name() : "-");
  return names;
}

TEST(RobustRules, ParseTheTextForms) {
  RobustRule r = ParseRobustRule("loop=huber:0.5");
  EXPECT_EQ(r.selector, "loop");
  EXPECT_EQ(r.loss->name(), "huber:0.5");
  EXPECT_EQ(ParseRobustRule("loop").loss->name(), "huber:1");  // the loop-closure default
  r = ParseRobustRule("EDGE_SE3:QUAT=dcs:2");                  // a tag with a colon: split at '='
  EXPECT_EQ(r.selector, "EDGE_SE3:QUAT");
  EXPECT_EQ(r.loss->name(), "dcs:2");
  for (const char* bad : {"=huber:1", "loop=", "loop=huber:-1", "loop=huber:1:2", "all=welsch:x"}) {
    try {
      ParseRobustRule(bad);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("'") + bad + "'"), std::string::npos) << e.what();
    }
  }
}

TEST(RobustRules, SelectLoopClosuresAllOrATagAndLaterRulesWin) {
  FactorGraph g = Graph();
  EXPECT_EQ(ApplyRobustRules({ParseRobustRule("loop=huber:1")}, DefaultRegistry(), &g), 1);
  EXPECT_EQ(Losses(g), (std::vector<std::string>{"-", "-", "huber:1", "-"}));

  g = Graph();
  EXPECT_EQ(ApplyRobustRules({ParseRobustRule("EDGE_SE2=cauchy:2")}, DefaultRegistry(), &g), 3);
  EXPECT_EQ(Losses(g), (std::vector<std::string>{"cauchy:2", "cauchy:2", "cauchy:2", "-"}));

  g = Graph();
  EXPECT_EQ(ApplyRobustRules({ParseRobustRule("all=cauchy:2"), ParseRobustRule("loop=dcs:1")}, DefaultRegistry(), &g),
            4);
  EXPECT_EQ(Losses(g), (std::vector<std::string>{"cauchy:2", "cauchy:2", "dcs:1", "cauchy:2"}));
}

TEST(RobustRules, AnUnknownTagChangesNothing) {
  FactorGraph g = Graph();
  try {
    ApplyRobustRules({ParseRobustRule("all=huber:1"), ParseRobustRule("EDGE_NOPE=huber:1")}, DefaultRegistry(), &g);
    ADD_FAILURE() << "an unknown tag was accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("'EDGE_NOPE'"), std::string::npos) << e.what();
  }
  EXPECT_EQ(Losses(g), (std::vector<std::string>{"-", "-", "-", "-"}));
}

TEST(RobustRules, ANameNotRegisteredYetIsLookedUpWhenTheRulesAreApplied) {
  LossRegistry losses = DefaultLossRegistry();
  const RobustRule later = ParseRobustRule("loop=later:2", losses);  // the form is checked, not the name
  EXPECT_EQ(later.loss, nullptr);
  EXPECT_EQ(later.loss_spec, "later:2");
  const RobustRule first = ParseRobustRule("all=cauchy:3", losses);
  ASSERT_NE(first.loss, nullptr);
  EXPECT_EQ(first.loss_spec, "cauchy:3");
  // Still unknown: refused listing the registered names, and the graph unchanged.
  FactorGraph g = Graph();
  try {
    ApplyRobustRules({first, later}, DefaultRegistry(), &g, losses);
    ADD_FAILURE() << "an unknown loss was accepted";
  } catch (const InvalidArgument& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("robust rule 'loop=later:2'"), std::string::npos) << m;
    EXPECT_NE(m.find("unknown kernel 'later'"), std::string::npos) << m;
    EXPECT_NE(m.find("registered: huber, cauchy, tukey, gm, dcs"), std::string::npos) << m;
  }
  EXPECT_EQ(Losses(g), (std::vector<std::string>{"-", "-", "-", "-"}));
  // Registered meanwhile (as a plugin's loss is by --plugin): the same rule now applies.
  LossEntry e;
  e.name = "later";
  e.owner = "test";
  e.make = [](double scale, double) { return std::make_shared<CauchyLoss>(scale); };
  losses.Register(e);
  EXPECT_EQ(ApplyRobustRules({first, later}, DefaultRegistry(), &g, losses), 4);
  EXPECT_EQ(Losses(g), (std::vector<std::string>{"cauchy:3", "cauchy:3", "cauchy:2", "cauchy:3"}));
  // A rule whose loss refuses its values is refused when applied, naming the rule.
  e.name = "picky";
  e.make = [](double, double) -> std::shared_ptr<const LossFunction> { throw InvalidArgument("never"); };
  losses.Register(e);
  try {
    ApplyRobustRules({ParseRobustRule("loop=picky:1", DefaultLossRegistry())}, DefaultRegistry(), &g, losses);
    ADD_FAILURE() << "a refused loss was applied";
  } catch (const InvalidArgument& x) {
    EXPECT_NE(std::string(x.what()).find("robust rule 'loop=picky:1': robust loss 'picky:1': never"), std::string::npos)
        << x.what();
  }
}

}  // namespace
}  // namespace tether
