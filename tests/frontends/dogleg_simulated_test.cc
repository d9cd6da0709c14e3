// Powell's dog-leg as a whole: on simulated worlds (Manhattan, sphere, landmarks) it reaches the
// optimum Levenberg-Marquardt reaches, undamped, and the report names it. Its steps and trust
// radius against the textbook formulas: tests/solvers/dogleg_test.cc.
#include <gtest/gtest.h>

#include "testing/simulated.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

TEST(DogLegTest, ReachesTheOptimumOfLevenbergMarquardtAndSaysSo) {
  for (SimWorld world : {SimWorld::kManhattan, SimWorld::kSphere, SimWorld::kLandmarks}) {
    const SimulatedGraph sim = testing::SimulateWorld(world, 300, 5);
    Values lm_values = sim.initial, dl_values = sim.initial;
    const SolverSummary lm = Optimize(sim.graph, &lm_values, {});
    SolverOptions o;
    o.algorithm = Algorithm::kDogLeg;
    const SolverSummary dl = Optimize(sim.graph, &dl_values, o);
    ASSERT_EQ(dl.status, SolverStatus::kConverged) << dl.FullReport();
    EXPECT_NEAR(dl.final_chi2, lm.final_chi2, 1e-6 * lm.final_chi2) << dl.FullReport();
    EXPECT_NE(dl.FullReport().find("dogleg / auto"), std::string::npos) << dl.FullReport();
    EXPECT_NE(dl.FullReport().find("initial_radius"), std::string::npos) << dl.FullReport();
    for (const IterationSummary& it : dl.log) EXPECT_EQ(it.lambda, 0.0);
  }
}

}  // namespace
}  // namespace tether
