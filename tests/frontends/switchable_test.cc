// Switchable constraints as a solve (tether/solvers/switchable.h) on a simulated Manhattan
// world with wrong loop closures: the switches of the wrong closures go to 0 and those of the
// true ones stay near 1; the augmented graph keeps the factor order; options.
#include "tether/solvers/switchable.h"

#include <gtest/gtest.h>

#include <set>

#include "testing/corrupted.h"
#include "tether/core/error.h"
#include "tether/factors/switchable.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

using testing::Corrupt;
using testing::Corrupted;
using testing::RmsFromFirstPose;

TEST(Switchable, SwitchesOffEveryWrongLoopClosure) {
  const Corrupted c = Corrupt(300, 0.3, 4);
  Values clean = c.initial;
  ASSERT_TRUE(Optimize(c.clean, &clean).IsSolutionUsable());
  Values v = c.initial;
  const SwitchableSummary s = OptimizeSwitchable(c.graph, &v);
  ASSERT_TRUE(s.usable) << s.message;
  EXPECT_EQ(v.size(), c.initial.size());  // the switches stay inside the solve
  const std::set<std::size_t> rejected(s.rejected.begin(), s.rejected.end());
  int true_rejected = 0;
  for (std::size_t i : c.wrong)
    EXPECT_TRUE(rejected.count(i)) << "wrong closure " << i << " kept, weight " << s.weights[i];
  for (std::size_t i : rejected) true_rejected += c.wrong.count(i) == 0;
  const int true_closures = s.loop_closures - static_cast<int>(c.wrong.size());
  EXPECT_EQ(true_closures, 161);
  EXPECT_LE(true_rejected, 0.02 * true_closures);
  double lowest_true = 1;
  for (std::size_t i = 0; i < c.graph.size(); ++i) {
    EXPECT_GE(s.weights[i], 0) << i;
    EXPECT_LE(s.weights[i], 1) << i;
    EXPECT_DOUBLE_EQ(s.weights[i], SwitchScale(s.switches[i]) * SwitchScale(s.switches[i])) << i;
    if (!c.graph.at(i).loop_closure()) {
      EXPECT_EQ(s.weights[i], 1) << "odometry " << i;
    }
    if (c.graph.at(i).loop_closure() && !c.wrong.count(i)) lowest_true = std::min(lowest_true, s.weights[i]);
  }
  EXPECT_GT(lowest_true, 0.1);  // measured 0.147
  // Every closure classified right: least squares over the kept ones is the clean optimum.
  EXPECT_LT(RmsFromFirstPose(v, clean), 1e-6);
  EXPECT_TRUE(s.refit.IsSolutionUsable());
}

TEST(Switchable, WithoutTheRefitSwitchesLeftPartlyOpenBendTheMap) {
  // The switched solution itself (refit off): every wrong closure is switched off, but the
  // true ones keep weights between 0.15 and 1, and the map is centimetres off the clean
  // optimum. Sünderhauf's prior (sigma 1) on this world, whose closures have chi2 near their
  // dimension at the optimum, switches off true closures too.
  const Corrupted c = Corrupt(300, 0.3, 4);
  Values clean = c.initial;
  ASSERT_TRUE(Optimize(c.clean, &clean).IsSolutionUsable());
  for (double sigma : {0.0, 1.0}) {
    SwitchableOptions o;
    o.refit = false;
    o.prior_sigma = sigma;
    Values v = c.initial;
    const SwitchableSummary s = OptimizeSwitchable(c.graph, &v, o);
    ASSERT_TRUE(s.usable) << s.message;
    EXPECT_EQ(s.refit.iterations, 0);
    int wrong_rejected = 0, true_rejected = 0;
    for (std::size_t i : s.rejected) (c.wrong.count(i) ? wrong_rejected : true_rejected)++;
    // Measured: 48 of 48 wrong closures off either way; sigma from the chi2 quantile: no true
    // one, 16 mm RMS; sigma 1: 150 of 161 true ones, 1.9 m.
    EXPECT_EQ(wrong_rejected, static_cast<int>(c.wrong.size())) << "sigma " << sigma;
    if (sigma == 0) {
      EXPECT_EQ(true_rejected, 0);
      EXPECT_GT(RmsFromFirstPose(v, clean), 1e-3);  // partly open switches bend the map ...
      EXPECT_LT(RmsFromFirstPose(v, clean), 0.05);  // ... by centimetres
    } else {
      EXPECT_GT(true_rejected, 100);
      EXPECT_GT(RmsFromFirstPose(v, clean), 0.5);
    }
  }
}

TEST(Switchable, WithSwitchesKeepsTheFactorOrderAndAddsOnePriorPerClosure) {
  const Corrupted c = Corrupt(60, 0.2, 2);
  Values v = c.initial;
  Key largest = 0;
  for (Key k : v.keys()) largest = std::max(largest, k);
  FactorGraph g = c.graph;
  g.Fix(0);
  std::vector<Key> switches;
  SwitchableOptions o;
  o.prior_sigma = 0.5;
  const FactorGraph s = WithSwitches(g, &v, o, &switches);
  int closures = 0;
  for (std::size_t i = 0; i < g.size(); ++i) closures += g.at(i).loop_closure();
  ASSERT_GT(closures, 3);
  ASSERT_EQ(switches.size(), static_cast<std::size_t>(closures));
  ASSERT_EQ(s.size(), g.size() + switches.size());
  EXPECT_TRUE(s.IsFixed(0));
  std::size_t next = 0;
  for (std::size_t i = 0; i < g.size(); ++i) {
    if (!g.at(i).loop_closure()) {
      EXPECT_EQ(s.at(i).type_name(), g.at(i).type_name()) << i;
      continue;
    }
    const auto* f = dynamic_cast<const SwitchableFactor*>(&s.at(i));
    ASSERT_NE(f, nullptr) << i;
    EXPECT_TRUE(f->loop_closure());
    EXPECT_EQ(f->switch_key(), largest + 1 + next) << i;
    EXPECT_EQ(f->switch_key(), switches[next]);
    EXPECT_EQ(v.At<Switch>(switches[next]).value, 1.0);
    // At s = 1 the switched closure costs what the plain one does.
    EXPECT_DOUBLE_EQ(f->Chi2(v), g.at(i).Chi2(v)) << i;
    ++next;
  }
  for (std::size_t k = 0; k < switches.size(); ++k) {
    const Factor& p = s.at(g.size() + k);
    EXPECT_EQ(p.type_name(), "SwitchPrior");
    EXPECT_EQ(p.keys()[0], switches[k]);
    Values off = v;
    off.Update(switches[k], Switch{0.0});
    EXPECT_DOUBLE_EQ(p.Chi2(off), 1 / (0.5 * 0.5));  // 1 / sigma^2 for a switch at 0
  }
}

TEST(Switchable, WithoutWrongClosuresTheMapIsTheLeastSquaresOne) {
  const Corrupted c = Corrupt(200, 0.0, 3);
  Values clean = c.initial;
  ASSERT_TRUE(Optimize(c.clean, &clean).IsSolutionUsable());
  Values v = c.initial;
  const SwitchableSummary s = OptimizeSwitchable(c.graph, &v);
  ASSERT_TRUE(s.usable) << s.message;
  double lowest = 1;
  for (double w : s.weights) lowest = std::min(lowest, w);
  EXPECT_TRUE(s.rejected.empty()) << s.rejected.size() << " rejected";
  EXPECT_GT(lowest, 0.1);  // measured 0.119: the switches of true closures do move
  EXPECT_LT(lowest, 1);
  EXPECT_NEAR(c.clean.Chi2(v), c.clean.Chi2(clean), 1e-9 * c.clean.Chi2(clean));
  EXPECT_LT(RmsFromFirstPose(v, clean), 1e-6);
}

TEST(Switchable, CeresReachesTheSameSwitchedOptimum) {
  // The Switch type and SwitchableFactor go through the Ceres adapter like any open type:
  // the switched solve (refit off) ends at the same cost with either solver.
  const Corrupted c = Corrupt(120, 0.2, 6);
  double chi2[2];
  for (int k = 0; k < 2; ++k) {
    SwitchableOptions o;
    o.refit = false;
    o.solver.algorithm = k == 0 ? Algorithm::kLevenbergMarquardt : Algorithm::kCeres;
    o.solver.max_iterations = 200;
    o.solver.function_tolerance = 1e-12;
    Values v = c.initial;
    const SwitchableSummary s = OptimizeSwitchable(c.graph, &v, o);
    ASSERT_TRUE(s.usable) << k << ": " << s.message;
    chi2[k] = s.solve.final_chi2;
    int wrong = 0;
    for (std::size_t i : s.rejected) wrong += c.wrong.count(i) != 0;
    EXPECT_EQ(wrong, static_cast<int>(c.wrong.size())) << k;
  }
  EXPECT_NEAR(chi2[1], chi2[0], 1e-4 * chi2[0]);
}

TEST(Switchable, AGraphWithoutAnAnchorKeepsItsGaugeAndGaussNewtonSolvesIt) {
  // The switch priors are one-key factors; without the fix WithSwitches adds, the solvers
  // would take them as anchors and leave the poses' gauge free (singular for Gauss-Newton).
  const Corrupted c = Corrupt(120, 0.2, 7);
  ASSERT_TRUE(c.graph.fixed().empty());
  Values v = c.initial;
  const FactorGraph s = WithSwitches(c.graph, &v);
  EXPECT_TRUE(s.IsFixed(0));  // the lowest-key pose, as the solvers would hold it
  FactorGraph anchored = c.graph;
  anchored.Fix(5);
  Values w = c.initial;
  const FactorGraph t = WithSwitches(anchored, &w);
  EXPECT_FALSE(t.IsFixed(0));
  EXPECT_TRUE(t.IsFixed(5));
  SwitchableOptions o;
  o.solver.algorithm = Algorithm::kGaussNewton;
  Values x = c.initial;
  const SwitchableSummary r = OptimizeSwitchable(c.graph, &x, o);
  ASSERT_TRUE(r.usable) << r.message;
  EXPECT_EQ(x.At<SE2d>(0).translation(), c.initial.At<SE2d>(0).translation());  // held
  int wrong = 0;
  for (std::size_t i : r.rejected) wrong += c.wrong.count(i) != 0;
  EXPECT_EQ(wrong, static_cast<int>(c.wrong.size()));
}

TEST(Switchable, InvalidOptionsThrow) {
  const Corrupted c = Corrupt(50, 0.0, 1);
  Values v = c.initial;
  SwitchableOptions o;
  o.prior_sigma = -1;
  EXPECT_THROW(OptimizeSwitchable(c.graph, &v, o), InvalidArgument);
  o = SwitchableOptions();
  o.reject_below = 2;
  EXPECT_THROW(OptimizeSwitchable(c.graph, &v, o), InvalidArgument);
  EXPECT_THROW(OptimizeSwitchable(c.graph, nullptr), InvalidArgument);
  o = SwitchableOptions();
  o.inlier_probability = 1;
  EXPECT_THROW(WithSwitches(c.graph, &v, o), InvalidArgument);
}

}  // namespace
}  // namespace tether
