// Powell's dog-leg (solvers/src/dogleg.cc): on a small problem its steps equal the ones worked
// out here from H and g by the textbook formulas, for a radius that takes the Gauss-Newton
// point, one that cuts the steepest-descent step, and one in between; the radius grows and
// shrinks by the gain ratio as DogLegOptions documents. The solver as a whole reaching the
// optimum Levenberg-Marquardt reaches on simulated worlds: tests/frontends/dogleg_simulated_test.cc.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <memory>

#include "builtin_linear_solvers.h"
#include "linear_system.h"
#include "problem.h"
#include "step_strategy.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/prior.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

// Two poses: a prior on x0 and an odometry edge to x1, with unequal weights, started away
// from the optimum, so that the Gauss-Newton and steepest-descent directions differ.
struct Small {
  FactorGraph graph;
  Values values;
};

Small MakeSmall() {
  Small s;
  s.graph.Add(std::make_unique<PriorSE2>(
      0, SE2d(0, 0, 0), SqrtInformation::FromInformation(Eigen::Vector3d(1, 4, 9).asDiagonal().toDenseMatrix())));
  s.graph.Add(std::make_unique<BetweenSE2>(
      0, 1, SE2d(1, 0, 0.1), SqrtInformation::FromInformation(Eigen::Vector3d(2, 3, 5).asDiagonal().toDenseMatrix())));
  s.values.Insert(0, SE2d(0.3, -0.2, 0.4));
  s.values.Insert(1, SE2d(1.5, 0.6, -0.3));
  return s;
}

// The linear system of the small problem at its start, and H and g from it.
struct Fixture {
  Small small = MakeSmall();
  internal::Problem problem{small.graph, &small.values, {}};
  std::unique_ptr<internal::LinearSystem> system;
  Eigen::MatrixXd H;
  Eigen::VectorXd g;

  Fixture() {
    problem.Linearize();
    system = std::make_unique<internal::LinearSystem>(&problem, *internal::LinearSolvers().Find("cholmod"),
                                                      LinearSolverOptions{});
    system->Assemble();
    const int n = problem.tangent_dim();
    H.resize(n, n);
    std::vector<double> e(n), col(n);
    for (int j = 0; j < n; ++j) {
      std::fill(e.begin(), e.end(), 0.0);
      e[j] = 1;
      system->MultiplyUndamped(e, &col);
      H.col(j) = Eigen::Map<Eigen::VectorXd>(col.data(), n);
    }
    g = Eigen::Map<const Eigen::VectorXd>(system->gradient().data(), n);
  }
  Eigen::VectorXd GaussNewton() const { return -H.ldlt().solve(g); }
  Eigen::VectorXd Cauchy() const { return -(g.squaredNorm() / g.dot(H * g)) * g; }

  // The first dog-leg step at this radius.
  Eigen::VectorXd Step(double radius, double* predicted = nullptr) {
    SolverOptions o;
    o.dogleg.initial_radius = radius;
    std::unique_ptr<internal::StepStrategy> dogleg = internal::MakeDogLeg(o);
    std::vector<double> delta(problem.tangent_dim());
    IterationSummary it;
    const internal::Step step = dogleg->ComputeStep(*system, &delta, &it);
    EXPECT_EQ(step.status, LinearSolverStatus::kOk);
    EXPECT_EQ(it.trust_radius, radius);
    if (predicted) *predicted = step.predicted_decrease;
    return Eigen::Map<Eigen::VectorXd>(delta.data(), delta.size());
  }
};

TEST(DogLegTest, TheTwoPointsDifferOnThisProblem) {
  Fixture f;
  ASSERT_EQ(f.H.rows(), 6);
  EXPECT_GT(f.GaussNewton().norm(), 1.5 * f.Cauchy().norm());
  EXPECT_LT(f.GaussNewton().normalized().dot(f.Cauchy().normalized()), 0.99);
}

TEST(DogLegTest, LargeRadiusTakesTheGaussNewtonPoint) {
  Fixture f;
  const Eigen::VectorXd gn = f.GaussNewton();
  double predicted = 0;
  const Eigen::VectorXd d = f.Step(2 * gn.norm(), &predicted);
  EXPECT_LT((d - gn).norm(), 1e-12 * gn.norm());
  // The model's decrease -2 g.d - d^T H d.
  EXPECT_NEAR(predicted, -2 * f.g.dot(d) - d.dot(f.H * d), 1e-12 * std::abs(predicted));
}

TEST(DogLegTest, SmallRadiusCutsTheSteepestDescentStep) {
  Fixture f;
  const double r = 0.5 * f.Cauchy().norm();
  const Eigen::VectorXd d = f.Step(r);
  const Eigen::VectorXd expected = -r / f.g.norm() * f.g;
  EXPECT_LT((d - expected).norm(), 1e-12 * r);
}

TEST(DogLegTest, RadiusBetweenTheTwoPointsBlendsThemOnTheSphere) {
  Fixture f;
  const Eigen::VectorXd gn = f.GaussNewton(), sd = f.Cauchy();
  const double r = 0.5 * (gn.norm() + sd.norm());
  const Eigen::VectorXd d = f.Step(r);
  // beta from |sd + beta (gn - sd)| = r, by the quadratic formula.
  const Eigen::VectorXd e = gn - sd;
  const double a = e.squaredNorm(), b = 2 * sd.dot(e), c = sd.squaredNorm() - r * r;
  const double beta = (-b + std::sqrt(b * b - 4 * a * c)) / (2 * a);
  ASSERT_GT(beta, 0);
  ASSERT_LT(beta, 1);
  EXPECT_LT((d - (sd + beta * e)).norm(), 1e-10 * r);
  EXPECT_NEAR(d.norm(), r, 1e-12 * r);
}

TEST(DogLegTest, ZeroInitialRadiusStartsWithTheGaussNewtonStep) {
  Fixture f;
  SolverOptions o;  // initial_radius 0
  std::unique_ptr<internal::StepStrategy> dogleg = internal::MakeDogLeg(o);
  std::vector<double> delta(f.problem.tangent_dim());
  IterationSummary it;
  dogleg->ComputeStep(*f.system, &delta, &it);
  const Eigen::VectorXd gn = f.GaussNewton();
  EXPECT_NEAR(it.trust_radius, gn.norm(), 1e-12 * gn.norm());
  EXPECT_LT((Eigen::Map<Eigen::VectorXd>(delta.data(), delta.size()) - gn).norm(), 1e-12 * gn.norm());
}

// The radius after one step of length |d| = r (the radius was reached) for a gain ratio rho.
double RadiusAfter(double rho, bool accepted, const DogLegOptions& options = {}) {
  Fixture f;
  const double r = 0.5 * f.Cauchy().norm();  // a cut steepest-descent step: |d| = r
  SolverOptions o;
  o.dogleg = options;
  o.dogleg.initial_radius = r;
  std::unique_ptr<internal::StepStrategy> dogleg = internal::MakeDogLeg(o);
  std::vector<double> delta(f.problem.tangent_dim());
  IterationSummary it;
  dogleg->ComputeStep(*f.system, &delta, &it);
  if (accepted) {
    dogleg->StepAccepted(rho);
  } else {
    dogleg->StepRejected();
  }
  IterationSummary next;
  dogleg->Describe(&next);
  return next.trust_radius / r;
}

TEST(DogLegTest, RadiusGrowsOnAGoodModelAndShrinksOnAPoorOne) {
  EXPECT_DOUBLE_EQ(RadiusAfter(0.9, true), 3.0);    // rho > 0.75: grow_factor times the step
  EXPECT_DOUBLE_EQ(RadiusAfter(0.5, true), 1.0);    // in between: unchanged
  EXPECT_DOUBLE_EQ(RadiusAfter(0.1, true), 0.25);   // rho < 0.25: shrink_factor times the step
  EXPECT_DOUBLE_EQ(RadiusAfter(0.0, false), 0.25);  // rejected
  DogLegOptions o;
  o.grow_factor = 2;
  o.shrink_factor = 0.5;
  EXPECT_DOUBLE_EQ(RadiusAfter(0.9, true, o), 2.0);
  EXPECT_DOUBLE_EQ(RadiusAfter(0.0, false, o), 0.5);
}

TEST(DogLegTest, GivesUpOnceTheRadiusIsBelowMinRadius) {
  SolverOptions o;
  o.dogleg.initial_radius = 1e-3;
  o.dogleg.min_radius = 1e-4;
  Fixture f;
  std::unique_ptr<internal::StepStrategy> dogleg = internal::MakeDogLeg(o);
  std::vector<double> delta(f.problem.tangent_dim());
  IterationSummary it;
  const char* why = nullptr;
  dogleg->ComputeStep(*f.system, &delta, &it);
  EXPECT_FALSE(dogleg->Exhausted(&why));
  dogleg->StepRejected();  // 2.5e-4
  EXPECT_FALSE(dogleg->Exhausted(&why));
  dogleg->ComputeStep(*f.system, &delta, &it);
  dogleg->StepRejected();  // 6.25e-5
  EXPECT_TRUE(dogleg->Exhausted(&why));
  EXPECT_NE(std::string(why).find("min_radius"), std::string::npos);
}

TEST(DogLegTest, OptionsAreValidated) {
  SolverOptions o;
  std::string why;
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.dogleg.shrink_factor = 1.5;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("dogleg.shrink_factor"), std::string::npos) << why;
  o = SolverOptions();
  o.dogleg.min_radius = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("dogleg.min_radius"), std::string::npos) << why;
}

TEST(DogLegTest, NameRoundTrips) {
  Algorithm a;
  ASSERT_TRUE(FromString("dogleg", &a));
  EXPECT_EQ(a, Algorithm::kDogLeg);
  EXPECT_STREQ(ToString(a), "dogleg");
  EXPECT_FALSE(FromString("powell", &a));
}

}  // namespace
}  // namespace tether
