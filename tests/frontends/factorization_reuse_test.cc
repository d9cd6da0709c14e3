// Reusing an earlier factorisation (SolverOptions::max_reuse_iterations): steps solved by
// conjugate gradients preconditioned with it reach the same optimum as steps that factorise
// every time, with fewer factorisations, and the log and summary say which steps did what.
#include <gtest/gtest.h>

#include <cmath>

#include "testing/simulated.h"
#include "tether/frontends/simulation/simulate.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

SimulatedGraph Sim(SimWorld w, int poses) { return testing::SimulateWorld(w, poses, 11); }

struct Case {
  SimWorld world;
  Algorithm algorithm;
  LinearSolverType linear;
};

class ReuseTest : public ::testing::TestWithParam<Case> {};

TEST_P(ReuseTest, SameOptimumWithFewerFactorisations) {
  const SimulatedGraph sim = Sim(GetParam().world, 400);
  SolverOptions every, reuse;
  every.algorithm = reuse.algorithm = GetParam().algorithm;
  every.linear_solver = reuse.linear_solver = GetParam().linear;
  every.linear.max_reuse_iterations = 0;
  Values a = sim.initial, b = sim.initial;
  const SolverSummary sa = Optimize(sim.graph, &a, every);
  const SolverSummary sb = Optimize(sim.graph, &b, reuse);
  ASSERT_EQ(sa.status, SolverStatus::kConverged) << sa.message;
  ASSERT_EQ(sb.status, SolverStatus::kConverged) << sb.message;

  // Factorising every step: one factorisation per iteration, no step marked reused.
  EXPECT_EQ(sa.factorizations, sa.iterations);
  for (const IterationSummary& it : sa.log) EXPECT_FALSE(it.reused_factorization);

  // Reusing: the count adds up, and at least one step (the last, small one) reused.
  int reused = 0;
  for (const IterationSummary& it : sb.log) {
    if (it.reused_factorization) {
      ++reused;
      EXPECT_LE(it.cg_iterations, reuse.linear.max_reuse_iterations);
    } else {
      EXPECT_EQ(it.cg_iterations, 0);
    }
  }
  EXPECT_EQ(sb.factorizations + reused, sb.iterations);
  EXPECT_GE(reused, 1);
  EXPECT_LT(sb.factorizations, sa.factorizations);

  // The same optimum: the steps are exact to 1e-3 in H-norm, so chi2 agrees to far better
  // than the function tolerance that ends both solves.
  EXPECT_NEAR(sb.final_chi2, sa.final_chi2, 1e-8 * sa.final_chi2);
  EXPECT_LE(std::abs(sb.iterations - sa.iterations), 1);
}

INSTANTIATE_TEST_SUITE_P(
    Worlds, ReuseTest,
    ::testing::Values(Case{SimWorld::kManhattan, Algorithm::kLevenbergMarquardt, LinearSolverType::kCholmod},
                      Case{SimWorld::kSphere, Algorithm::kLevenbergMarquardt, LinearSolverType::kCholmod},
                      Case{SimWorld::kLandmarks, Algorithm::kGaussNewton, LinearSolverType::kCholmod},
                      Case{SimWorld::kManhattan, Algorithm::kGaussNewton, LinearSolverType::kEigenLDLT}));

// QR solves the Jacobian itself and has no factorisation of H to reuse.
TEST(ReuseTest, QrFactorisesEveryStep) {
  const SimulatedGraph sim = Sim(SimWorld::kManhattan, 200);
  SolverOptions o;
  o.linear_solver = LinearSolverType::kQR;
  Values v = sim.initial;
  const SolverSummary s = Optimize(sim.graph, &v, o);
  ASSERT_EQ(s.status, SolverStatus::kConverged) << s.message;
  EXPECT_EQ(s.factorizations, s.iterations);
}

// A step whose conjugate gradients cannot converge in the iterations allowed is solved by a
// fresh factorisation: with one iteration allowed the solve still reaches the optimum.
TEST(ReuseTest, FallsBackToAFreshFactorisation) {
  const SimulatedGraph sim = Sim(SimWorld::kSphere, 300);
  SolverOptions every, one;
  every.linear.max_reuse_iterations = 0;
  one.linear.max_reuse_iterations = 1;
  Values a = sim.initial, b = sim.initial;
  const SolverSummary sa = Optimize(sim.graph, &a, every);
  const SolverSummary sb = Optimize(sim.graph, &b, one);
  ASSERT_EQ(sb.status, SolverStatus::kConverged) << sb.message;
  int factorised_later = 0;  // steps after the first that did not reuse: fell back
  for (const IterationSummary& it : sb.log) {
    EXPECT_LE(it.cg_iterations, 1);
    if (it.iteration > 1 && !it.reused_factorization) ++factorised_later;
  }
  EXPECT_GE(factorised_later, 1);
  EXPECT_NEAR(sb.final_chi2, sa.final_chi2, 1e-8 * sa.final_chi2);
}

TEST(ReuseTest, NegativeIterationsAreRejected) {
  SolverOptions o;
  o.linear.max_reuse_iterations = -1;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("max_reuse_iterations"), std::string::npos) << why;
}

}  // namespace
}  // namespace tether
