// Gauss-Newton and Levenberg-Marquardt on synthetic graphs with known ground truth, the
// three linear solvers against each other, stopping rules, gauge handling and failures.
#include "tether/solvers/optimizer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/prior.h"
#include "tether/frontends/simulation/simulate.h"

namespace tether {
namespace {

SimulatedGraph Sim(SimWorld w, int poses, double sigma_scale = 1.0, std::uint64_t seed = 3) {
  SimulateOptions o;
  o.world = w;
  o.poses = poses;
  o.seed = seed;
  o.translation_sigma *= sigma_scale;
  o.rotation_sigma *= sigma_scale;
  return Simulate(o);
}

// Largest position error of any variable against the truth (poses and points).
double MaxPositionError(const Values& a, const Values& b) {
  double worst = 0;
  for (Key k : a.keys()) {
    const double* p = a.Params(k);
    const double* q = b.Params(k);
    const int n = a.TypeOf(k) == VarType::kSE2 || a.TypeOf(k) == VarType::kPoint2 ? 2 : 3;
    double d = 0;
    for (int i = 0; i < n; ++i) d += (p[i] - q[i]) * (p[i] - q[i]);
    worst = std::max(worst, std::sqrt(d));
  }
  return worst;
}

bool AllFinite(const Values& v) {
  for (int t = 0; t < kNumBuiltinVarTypes; ++t)
    for (double x : v.Data(static_cast<VarType>(t)))
      if (!std::isfinite(x)) return false;
  return true;
}

struct Case {
  SimWorld world;
  Algorithm algorithm;
  LinearSolverType linear;
};

class GroundTruthTest : public ::testing::TestWithParam<Case> {};

TEST_P(GroundTruthTest, SolvesBackToGroundTruth) {
  // Very small noise: the optimum lies within millimetres of the truth, while the composed
  // odometry start is far off (drift over hundreds of poses).
  SimulatedGraph sim = Sim(GetParam().world, 300, 0.01);
  Values values = sim.initial;
  const double start_error = MaxPositionError(values, sim.ground_truth);
  SolverOptions o;
  o.algorithm = GetParam().algorithm;
  o.linear_solver = GetParam().linear;
  const SolverSummary s = Optimize(sim.graph, &values, o);
  ASSERT_EQ(s.status, SolverStatus::kConverged) << s.FullReport();
  EXPECT_TRUE(s.gauge_fixed_automatically);
  EXPECT_EQ(s.gauge_key, 0u);
  // The optimum can only be below the chi2 of the truth.
  EXPECT_LE(s.final_chi2, sim.graph.Chi2(sim.ground_truth));
  EXPECT_NEAR(s.final_chi2, sim.graph.Chi2(values), 1e-9 * s.final_chi2);
  const double end_error = MaxPositionError(values, sim.ground_truth);
  EXPECT_LT(end_error, 0.02) << "start error " << start_error;
}

INSTANTIATE_TEST_SUITE_P(
    Worlds, GroundTruthTest,
    ::testing::Values(Case{SimWorld::kManhattan, Algorithm::kLevenbergMarquardt, LinearSolverType::kCholmod},
                      Case{SimWorld::kManhattan, Algorithm::kGaussNewton, LinearSolverType::kEigenLDLT},
                      Case{SimWorld::kManhattan, Algorithm::kLevenbergMarquardt, LinearSolverType::kQR},
                      Case{SimWorld::kSphere, Algorithm::kLevenbergMarquardt, LinearSolverType::kCholmod},
                      Case{SimWorld::kSphere, Algorithm::kGaussNewton, LinearSolverType::kQR},
                      Case{SimWorld::kLandmarks, Algorithm::kLevenbergMarquardt, LinearSolverType::kCholmod},
                      Case{SimWorld::kLandmarks, Algorithm::kGaussNewton, LinearSolverType::kEigenLDLT}),
    [](const ::testing::TestParamInfo<Case>& i) {
      return std::string(ToString(i.param.world)) + "_" + ToString(i.param.algorithm) + "_" + ToString(i.param.linear);
    });

TEST(OptimizerTest, LinearSolversAgree) {
  const SimulatedGraph sim = Sim(SimWorld::kManhattan, 400);
  double reference = -1;
  for (LinearSolverType t : {LinearSolverType::kCholmod, LinearSolverType::kEigenLDLT, LinearSolverType::kQR}) {
    Values v = sim.initial;
    SolverOptions o;
    o.linear_solver = t;
    const SolverSummary s = Optimize(sim.graph, &v, o);
    ASSERT_EQ(s.status, SolverStatus::kConverged) << ToString(t) << ": " << s.message;
    if (reference < 0) reference = s.final_chi2;
    EXPECT_NEAR(s.final_chi2, reference, 1e-8 * reference) << ToString(t);
  }
}

TEST(OptimizerTest, LevenbergMarquardtNeverRaisesChi2) {
  const SimulatedGraph sim = Sim(SimWorld::kSphere, 300, 5.0);
  Values v = sim.initial;
  SolverOptions o;             // the default starts undamped, so that rejections happen
  o.lm.max_step_halvings = 0;  // (with halvings, this start has no rejections)
  int rejected = 0;
  const SolverSummary s = Optimize(sim.graph, &v, o);
  double last = s.initial_chi2;
  for (const IterationSummary& it : s.log) {
    EXPECT_LE(it.chi2, last) << "iteration " << it.iteration;
    last = it.chi2;
    rejected += it.accepted ? 0 : 1;
  }
  EXPECT_GT(rejected, 0) << "the test no longer exercises rejection; make the start worse";
  EXPECT_LE(s.final_chi2, s.initial_chi2);
  EXPECT_EQ(s.iterations, static_cast<int>(s.log.size()) - 1);
  EXPECT_EQ(s.accepted_iterations, s.iterations - rejected);
}

// The damping policy: the first step is undamped; a rejected undamped step restarts the
// damping at min_lambda; damping is never between 0 and min_lambda; and it grows on every
// further rejection.
TEST(OptimizerTest, LevenbergMarquardtDampsOnlyAfterARejection) {
  const SimulatedGraph sim = Sim(SimWorld::kSphere, 300, 5.0);
  Values v = sim.initial;
  SolverOptions o;
  o.lm.max_step_halvings = 0;
  const SolverSummary s = Optimize(sim.graph, &v, o);
  ASSERT_GE(s.log.size(), 2u);
  EXPECT_EQ(s.log[1].lambda, 0.0);
  bool restarted = false;
  for (std::size_t i = 1; i < s.log.size(); ++i) {
    const IterationSummary& it = s.log[i];
    EXPECT_TRUE(it.lambda == 0.0 || it.lambda >= o.lm.min_lambda) << "iteration " << i << " lambda " << it.lambda;
    if (i + 1 < s.log.size() && !it.accepted) {
      const double next = s.log[i + 1].lambda;
      if (it.lambda == 0.0) {
        EXPECT_EQ(next, o.lm.min_lambda) << "iteration " << i + 1;
        restarted = true;
      } else {
        EXPECT_GT(next, it.lambda) << "iteration " << i + 1;
      }
    }
  }
  EXPECT_TRUE(restarted) << "no undamped step was rejected; make the start worse";
}

// An undamped step that raises chi2 is halved (at most max_step_halvings times) before the
// damping starts; with no halvings allowed, none happen.
TEST(OptimizerTest, LevenbergMarquardtHalvesAnOvershootingUndampedStep) {
  const SimulatedGraph sim = Sim(SimWorld::kSphere, 300, 5.0);
  int halved_and_kept = 0;
  for (int halvings : {0, 1, 3}) {
    Values v = sim.initial;
    SolverOptions o;
    o.lm.max_step_halvings = halvings;
    const SolverSummary s = Optimize(sim.graph, &v, o);
    EXPECT_TRUE(s.IsSolutionUsable()) << s.message;
    int seen = 0;
    for (const IterationSummary& it : s.log) {
      EXPECT_LE(it.step_halvings, halvings);
      if (it.step_halvings > 0) {
        EXPECT_EQ(it.lambda, 0.0);  // only undamped steps are halved
        ++seen;
        if (it.accepted) ++halved_and_kept;
      }
    }
    if (halvings == 0) {
      EXPECT_EQ(seen, 0);
    } else {
      EXPECT_GT(seen, 0) << "no undamped step overshot; make the start worse";
    }
  }
  EXPECT_GT(halved_and_kept, 0);
}

// Where Gauss-Newton never raises chi2, LM takes exactly its steps.
TEST(OptimizerTest, LevenbergMarquardtFollowsGaussNewtonWhileItWorks) {
  const SimulatedGraph sim = Sim(SimWorld::kManhattan, 400);
  Values gn_values = sim.initial, lm_values = sim.initial;
  SolverOptions gn, lm;
  gn.algorithm = Algorithm::kGaussNewton;
  const SolverSummary a = Optimize(sim.graph, &gn_values, gn);
  const SolverSummary b = Optimize(sim.graph, &lm_values, lm);
  ASSERT_EQ(a.status, SolverStatus::kConverged);
  for (std::size_t i = 1; i < a.log.size(); ++i) ASSERT_LT(a.log[i].chi2, a.log[i - 1].chi2) << i;
  ASSERT_EQ(a.log.size(), b.log.size());
  for (std::size_t i = 1; i < a.log.size(); ++i) {
    EXPECT_EQ(b.log[i].lambda, 0.0);
    EXPECT_EQ(b.log[i].chi2, a.log[i].chi2) << "iteration " << i;
  }
}

TEST(OptimizerTest, CallbackSeesEveryIteration) {
  const SimulatedGraph sim = Sim(SimWorld::kManhattan, 100);
  Values v = sim.initial;
  std::vector<int> seen;
  SolverOptions o;
  o.callback = [&](const IterationSummary& it) { seen.push_back(it.iteration); };
  const SolverSummary s = Optimize(sim.graph, &v, o);
  ASSERT_EQ(static_cast<int>(seen.size()), s.iterations + 1);
  for (std::size_t i = 0; i < seen.size(); ++i) EXPECT_EQ(seen[i], static_cast<int>(i));
}

// keep_going returning false ends the solve with status kStopped and the values of the
// iteration it saw, for every algorithm (Ceres included); at iteration 0 nothing moves.
TEST(OptimizerTest, KeepGoingStopsTheSolve) {
  const SimulatedGraph sim = Sim(SimWorld::kManhattan, 300);
  for (Algorithm a : {Algorithm::kGaussNewton, Algorithm::kLevenbergMarquardt, Algorithm::kDogLeg, Algorithm::kCeres}) {
    SCOPED_TRACE(a.name());
    SolverOptions o;
    o.algorithm = a;
    Values full = sim.initial;
    const SolverSummary whole = Optimize(sim.graph, &full, o);
    ASSERT_GE(whole.iterations, 2);
    std::vector<IterationSummary> seen;
    o.callback = [&](const IterationSummary& it) { seen.push_back(it); };
    o.keep_going = [](const IterationSummary& it) { return it.iteration < 1; };
    Values v = sim.initial;
    const SolverSummary s = Optimize(sim.graph, &v, o);
    EXPECT_EQ(s.status, SolverStatus::kStopped) << s.message;
    EXPECT_TRUE(s.IsSolutionUsable());
    EXPECT_NE(s.message.find("after iteration 1"), std::string::npos) << s.message;
    EXPECT_EQ(s.iterations, 1);
    ASSERT_FALSE(seen.empty());
    EXPECT_EQ(seen.back().iteration, 1);
    // The values are those of the state the callback saw at iteration 1.
    EXPECT_NEAR(sim.graph.Chi2(v), seen.back().chi2, 1e-9 * seen.back().chi2);
    EXPECT_NEAR(s.final_chi2, seen.back().chi2, 1e-9 * seen.back().chi2);
    EXPECT_GT(s.final_chi2, whole.final_chi2);
    EXPECT_LT(s.final_chi2, s.initial_chi2);
    // Stopped at the start: no iteration, values untouched.
    o.keep_going = [](const IterationSummary&) { return false; };
    Values untouched = sim.initial;
    const SolverSummary s0 = Optimize(sim.graph, &untouched, o);
    EXPECT_EQ(s0.status, SolverStatus::kStopped) << s0.message;
    EXPECT_EQ(s0.iterations, 0);
    EXPECT_NEAR(sim.graph.Chi2(untouched), sim.graph.Chi2(sim.initial), 1e-9 * sim.graph.Chi2(sim.initial));
  }
}

TEST(OptimizerTest, MaxIterationsAndTimeLimitStop) {
  const SimulatedGraph sim = Sim(SimWorld::kManhattan, 300);
  Values v = sim.initial;
  SolverOptions o;
  o.max_iterations = 1;
  SolverSummary s = Optimize(sim.graph, &v, o);
  EXPECT_EQ(s.status, SolverStatus::kMaxIterations);
  EXPECT_EQ(s.iterations, 1);
  EXPECT_TRUE(s.IsSolutionUsable());
  v = sim.initial;
  o.max_iterations = 100;
  o.max_seconds = 1e-9;
  s = Optimize(sim.graph, &v, o);
  EXPECT_EQ(s.status, SolverStatus::kTimeLimit);
  EXPECT_LE(s.iterations, 1);
}

TEST(OptimizerTest, LooseToleranceStopsEarlier) {
  const SimulatedGraph sim = Sim(SimWorld::kManhattan, 300);
  Values a = sim.initial, b = sim.initial;
  SolverOptions tight, loose;
  loose.function_tolerance = 1e-2;
  const SolverSummary st = Optimize(sim.graph, &a, tight);
  const SolverSummary sl = Optimize(sim.graph, &b, loose);
  EXPECT_EQ(sl.status, SolverStatus::kConverged);
  EXPECT_LT(sl.iterations, st.iterations);
  EXPECT_GE(sl.final_chi2, st.final_chi2);
}

TEST(OptimizerTest, InvalidOptionsLeaveValuesUntouched) {
  const SimulatedGraph sim = Sim(SimWorld::kManhattan, 50);
  Values v = sim.initial;
  SolverOptions o;
  o.max_iterations = -1;
  const SolverSummary s = Optimize(sim.graph, &v, o);
  EXPECT_EQ(s.status, SolverStatus::kInvalidInput);
  EXPECT_NE(s.message.find("max_iterations"), std::string::npos);
  EXPECT_EQ(v.Data(VarType::kSE2), sim.initial.Data(VarType::kSE2));
}

TEST(OptimizerTest, DampingOptionsAreValidated) {
  std::string why;
  SolverOptions o;
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.lm.initial_lambda = -1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("initial_lambda"), std::string::npos) << why;
  o = SolverOptions();
  o.lm.min_lambda = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("min_lambda"), std::string::npos) << why;
  o = SolverOptions();
  o.lm.max_lambda = o.lm.min_lambda / 2;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("max_lambda"), std::string::npos) << why;
}

TEST(OptimizerTest, NonFiniteStartIsRejected) {
  SimulatedGraph sim = Sim(SimWorld::kManhattan, 50);
  Values v = sim.initial;
  v.Params(5)[0] = std::nan("");
  const SolverSummary s = Optimize(sim.graph, &v, {});
  EXPECT_EQ(s.status, SolverStatus::kInvalidInput);
  EXPECT_NE(s.message.find("not finite"), std::string::npos);
}

TEST(OptimizerTest, MissingVariableIsInvalidInput) {
  FactorGraph g;
  g.Add(std::make_unique<BetweenSE2>(0, 7, SE2d(1, 0, 0), SqrtInformation::Identity(3)));
  Values v;
  v.Insert(0, SE2d());
  const SolverSummary s = Optimize(g, &v, {});
  EXPECT_EQ(s.status, SolverStatus::kInvalidInput);
  EXPECT_NE(s.message.find("7"), std::string::npos) << s.message;
}

TEST(OptimizerTest, DisconnectedGraphIsRankDeficientAndKeepsValuesFinite) {
  // Two pieces: 0-1 and 2-3. Fixing pose 0 leaves the second piece floating.
  FactorGraph g;
  g.Add(std::make_unique<BetweenSE2>(0, 1, SE2d(1, 0, 0), SqrtInformation::Identity(3)));
  g.Add(std::make_unique<BetweenSE2>(2, 3, SE2d(1, 0, 0), SqrtInformation::Identity(3)));
  Values v;
  for (Key k = 0; k < 4; ++k) v.Insert(k, SE2d(0.5 * k, 0.1, 0.2));
  for (LinearSolverType t : {LinearSolverType::kCholmod, LinearSolverType::kEigenLDLT, LinearSolverType::kQR}) {
    for (Algorithm a : {Algorithm::kGaussNewton, Algorithm::kLevenbergMarquardt}) {
      Values w = v;
      SolverOptions o;
      o.linear_solver = t;
      o.algorithm = a;
      const SolverSummary s = Optimize(g, &w, o);
      // LM's damping makes the system solvable, so it may converge with the floating piece
      // left where it was; either way nothing non-finite is produced.
      if (a == Algorithm::kGaussNewton) {
        EXPECT_EQ(s.status, SolverStatus::kRankDeficient) << ToString(t) << " " << s.message;
        EXPECT_NE(s.message.find("connected"), std::string::npos);
      }
      EXPECT_TRUE(AllFinite(w)) << ToString(t);
    }
  }
}

TEST(OptimizerTest, FixedAndPriorRemoveTheAutomaticGauge) {
  SimulatedGraph sim = Sim(SimWorld::kManhattan, 60);
  {
    FactorGraph g = sim.graph;
    g.Fix(10);
    Values v = sim.initial;
    const SE2d before = v.At<SE2d>(10);
    const SolverSummary s = Optimize(g, &v, {});
    EXPECT_FALSE(s.gauge_fixed_automatically);
    EXPECT_EQ(s.num_fixed, 1);
    EXPECT_EQ(v.At<SE2d>(10).x(), before.x());
    EXPECT_EQ(v.At<SE2d>(10).theta(), before.theta());
  }
  {
    FactorGraph g = sim.graph;
    g.Add(std::make_unique<PriorSE2>(0, SE2d(1, 2, 0.5), SqrtInformation::Isotropic(3, 1e-3)));
    Values v = sim.initial;
    const SolverSummary s = Optimize(g, &v, {});
    EXPECT_FALSE(s.gauge_fixed_automatically);
    EXPECT_EQ(s.num_fixed, 0);
    EXPECT_EQ(s.status, SolverStatus::kConverged);
    EXPECT_NEAR(v.At<SE2d>(0).x(), 1.0, 1e-3);
    EXPECT_NEAR(v.At<SE2d>(0).theta(), 0.5, 1e-3);
  }
}

TEST(OptimizerTest, EverythingFixedIsANoOp) {
  SimulatedGraph sim = Sim(SimWorld::kManhattan, 5);
  FactorGraph g = sim.graph;
  for (Key k : sim.initial.keys()) g.Fix(k);
  Values v = sim.initial;
  const SolverSummary s = Optimize(g, &v, {});
  EXPECT_EQ(s.status, SolverStatus::kConverged);
  EXPECT_EQ(s.iterations, 0);
  EXPECT_DOUBLE_EQ(s.final_chi2, s.initial_chi2);
}

TEST(SolverOptionsTest, NamesRoundTrip) {
  for (Algorithm a : {Algorithm::kGaussNewton, Algorithm::kLevenbergMarquardt}) {
    Algorithm b;
    ASSERT_TRUE(FromString(ToString(a), &b));
    EXPECT_EQ(a, b);
  }
  for (LinearSolverType a : {LinearSolverType::kCholmod, LinearSolverType::kEigenLDLT, LinearSolverType::kQR}) {
    LinearSolverType b;
    ASSERT_TRUE(FromString(ToString(a), &b));
    EXPECT_EQ(a, b);
  }
  for (int i = 0; i <= static_cast<int>(SolverStatus::kStopped); ++i) {
    SolverStatus b;
    ASSERT_TRUE(FromString(ToString(static_cast<SolverStatus>(i)), &b));
    EXPECT_EQ(static_cast<int>(b), i);
  }
  Algorithm a;
  EXPECT_FALSE(FromString("newton", &a));
}

TEST(SolverSummaryTest, ReportsNameWhatHappened) {
  SimulatedGraph sim = Sim(SimWorld::kManhattan, 50);
  Values v = sim.initial;
  const SolverSummary s = Optimize(sim.graph, &v, {});
  const std::string full = s.FullReport();
  EXPECT_NE(full.find("converged"), std::string::npos);
  EXPECT_NE(full.find("held 0 fixed"), std::string::npos);
  EXPECT_NE(s.BriefReport().find("converged"), std::string::npos);
  std::ostringstream printed;
  printed << s;
  EXPECT_EQ(printed.str(), s.BriefReport());
}

}  // namespace
}  // namespace tether
