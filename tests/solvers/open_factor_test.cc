// The caps are gone: a factor with a residual of size 9 on 5 variables (autodiff through
// value types) solves with every linear solver and with Ceres, to the closed-form optimum of
// the linear least-squares problem it makes. And robust losses: a Gauss-Newton step under a
// loss is the reweighted least-squares step computed by hand; every algorithm, Ceres too,
// ends at a stationary point of the robust cost; the summary reports cost and chi2 apart.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "tether/core/autodiff_factor.h"
#include "tether/core/jacobian_check.h"
#include "tether/core/robust_kernels.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
constexpr int kRows = 9, kCols = 14;  // 3 + 3 + 3 + 3 + 2 unknowns

// e = A x - b over five point variables stacked as x (14 entries).
class Linear9 : public AutoDiffFactor<Linear9, kRows, Vec3, Vec3, Vec3, Vec3, Vec2> {
 public:
  static constexpr const char* kTypeName = "TestLinear9";
  Linear9(std::vector<Key> keys, const Eigen::Matrix<double, kRows, kCols>& a, const Eigen::Matrix<double, kRows, 1>& b)
      : AutoDiffFactor(std::move(keys), SqrtInformation::Identity(kRows)), a_(a), b_(b) {}
  template <typename T>
  bool operator()(const T* const* p, T* e) const {
    const int sizes[5] = {3, 3, 3, 3, 2};
    for (int r = 0; r < kRows; ++r) {
      T s = T(-b_[r]);
      int c = 0;
      for (int k = 0; k < 5; ++k)
        for (int i = 0; i < sizes[k]; ++i) s += a_(r, c++) * p[k][i];
      e[r] = s;
    }
    return true;
  }

 private:
  Eigen::Matrix<double, kRows, kCols> a_;
  Eigen::Matrix<double, kRows, 1> b_;
};

template <class V>
class PointPrior : public AutoDiffFactor<PointPrior<V>, V::RowsAtCompileTime, V> {
 public:
  static constexpr const char* kTypeName = V::RowsAtCompileTime == 2 ? "TestPrior2" : "TestPrior3";
  PointPrior(Key k, const V& z)
      : AutoDiffFactor<PointPrior, V::RowsAtCompileTime, V>({k}, SqrtInformation::Identity(V::RowsAtCompileTime)),
        z_(z) {}
  template <typename T>
  bool operator()(const T* const* p, T* e) const {
    for (int i = 0; i < V::RowsAtCompileTime; ++i) e[i] = p[0][i] - T(z_[i]);
    return true;
  }
  const V& measurement() const { return z_; }

 private:
  V z_;
};

struct Problem9 {
  FactorGraph graph;
  Values values;
  Eigen::Matrix<double, kCols, 1> optimum;
};

Problem9 Make() {
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, 1);
  Eigen::Matrix<double, kRows, kCols> a;
  Eigen::Matrix<double, kRows, 1> b;
  Eigen::Matrix<double, kCols, 1> x0;
  for (int i = 0; i < a.size(); ++i) a.data()[i] = n(rng);
  for (int i = 0; i < b.size(); ++i) b[i] = n(rng);
  for (int i = 0; i < x0.size(); ++i) x0[i] = n(rng);
  Problem9 p;
  const std::vector<Key> keys = {1, 2, 3, 4, 5};
  p.graph.Add(std::make_unique<Linear9>(keys, a, b));
  for (int k = 0; k < 4; ++k) {
    p.graph.Add(std::make_unique<PointPrior<Vec3>>(keys[k], Vec3(x0.segment<3>(3 * k))));
    p.values.Insert(keys[k], Vec3(10, -10, 10));
  }
  p.graph.Add(std::make_unique<PointPrior<Vec2>>(keys[4], Vec2(x0.segment<2>(12))));
  p.values.Insert(keys[4], Vec2(-5, 5));
  // min |A x - b|^2 + |x - x0|^2:  (A^T A + I) x = A^T b + x0.
  const Eigen::Matrix<double, kCols, kCols> h = a.transpose() * a + Eigen::Matrix<double, kCols, kCols>::Identity();
  p.optimum = h.ldlt().solve(a.transpose() * b + x0);
  return p;
}

Eigen::Matrix<double, kCols, 1> Stack(const Values& v) {
  Eigen::Matrix<double, kCols, 1> x;
  for (int k = 0; k < 4; ++k) x.segment<3>(3 * k) = v.At<Vec3>(k + 1);
  x.segment<2>(12) = v.At<Vec2>(5);
  return x;
}

TEST(OpenFactorTest, NineResidualsOnFiveVariablesHaveExactJacobians) {
  Problem9 p = Make();
  const JacobianCheck c = CheckJacobians(p.graph.at(0), p.values);
  EXPECT_TRUE(c.ok) << c.Report();
  EXPECT_EQ(p.graph.at(0).variable_types().size(), 5u);
  EXPECT_EQ(p.graph.at(0).residual_dim(), 9);
}

class OpenFactorSolveTest : public ::testing::TestWithParam<std::pair<const char*, const char*>> {};

TEST_P(OpenFactorSolveTest, NineResidualsOnFiveVariablesSolveToTheClosedForm) {
  Problem9 p = Make();
  SolverOptions o;
  ASSERT_TRUE(FromString(GetParam().first, &o.algorithm));
  ASSERT_TRUE(FromString(GetParam().second, &o.linear_solver));
  const SolverSummary s = Optimize(p.graph, &p.values, o);
  ASSERT_TRUE(s.IsSolutionUsable()) << s.FullReport();
  // The native solvers take the Gauss-Newton step of this linear problem exactly. Ceres' LM
  // starts inside a trust region and stops at its relative function tolerance (1e-8 of the
  // cost, about 1e-7 in x here), so it gets a looser bound.
  const double tolerance = o.algorithm == Algorithm::kCeres ? 1e-6 : 1e-8;
  EXPECT_LT((Stack(p.values) - p.optimum).norm(), tolerance) << s.FullReport();
  EXPECT_EQ(s.num_variables, 5);
  EXPECT_EQ(s.tangent_dim, kCols);
}

INSTANTIATE_TEST_SUITE_P(Solvers, OpenFactorSolveTest,
                         ::testing::Values(std::make_pair("gn", "cholmod"), std::make_pair("lm", "cholmod"),
                                           std::make_pair("lm", "ldlt"), std::make_pair("lm", "qr"),
                                           std::make_pair("ceres", "cholmod")));

// Three priors on one 2D point, each under a robust loss: two near the origin and one far
// off (an outlier). Its cost F(x) = sum rho(|x - z_i|^2).
struct RobustPoint {
  FactorGraph graph;
  Values values;
};

RobustPoint MakeRobustPoint(const std::string& loss) {
  RobustPoint p;
  for (const Vec2& z : {Vec2(0, 0), Vec2(0.2, -0.1), Vec2(6, 5)}) {
    p.graph.Add(std::make_unique<PointPrior<Vec2>>(1, z));
    p.graph.at(p.graph.size() - 1).set_loss(MakeLoss(loss));
  }
  p.values.Insert(1, Vec2(1.5, 1));
  return p;
}

// The gradient of the graph's cost at x by central differences.
Vec2 CostGradient(const FactorGraph& graph, const Vec2& x) {
  Vec2 g;
  for (int i = 0; i < 2; ++i) {
    const double h = 1e-6;
    Values up, down;
    up.Insert(1, Vec2(x + h * Vec2::Unit(i)));
    down.Insert(1, Vec2(x - h * Vec2::Unit(i)));
    g[i] = (graph.Cost(up) - graph.Cost(down)) / (2 * h);
  }
  return g;
}

// The point after one reweighted step with damping lambda (relative to diag(H)): with
// w_i = rho'(|x - z_i|^2), x - sum w_i (x - z_i) / ((1 + lambda) sum w_i).
Vec2 ReweightedStepByHand(const RobustPoint& p, double lambda) {
  const Vec2 x = p.values.At<Vec2>(1);
  Vec2 num = Vec2::Zero();
  double den = 0;
  for (std::size_t i = 0; i < p.graph.size(); ++i) {
    const Vec2 e = x - static_cast<const PointPrior<Vec2>&>(p.graph.at(i)).measurement();
    double rho[3];
    p.graph.at(i).loss()->Evaluate(e.squaredNorm(), rho);
    num += rho[1] * e;
    den += rho[1];
  }
  return x - num / ((1 + lambda) * den);
}

TEST(RobustSolveTest, AGaussNewtonStepIsTheReweightedLeastSquaresStepByHand) {
  // Iteratively reweighted least squares: each factor's residual and Jacobian are weighted by
  // sqrt(rho'(s)) at the current point, so the step solves sum_i w_i (x + d - z_i) = 0 with
  // w_i = rho'(|x - z_i|^2): d = -sum w_i (x - z_i) / sum w_i.
  for (const char* loss : {"huber:1", "cauchy:1", "gm:2", "dcs:1", "tukey:4"}) {
    RobustPoint p = MakeRobustPoint(loss);
    const Vec2 by_hand = ReweightedStepByHand(p, 0);
    SolverOptions o;
    o.algorithm = Algorithm::kGaussNewton;
    o.max_iterations = 1;
    const SolverSummary s = Optimize(p.graph, &p.values, o);
    ASSERT_TRUE(s.IsSolutionUsable()) << loss << ": " << s.FullReport();
    EXPECT_LT((p.values.At<Vec2>(1) - by_hand).norm(), 1e-12)
        << loss << ": solver " << p.values.At<Vec2>(1).transpose() << ", by hand " << by_hand.transpose();
  }
}

TEST(RobustSolveTest, ALevenbergMarquardtStepIsTheDampedReweightedStepByHand) {
  // LM solves (H + lambda diag(H)) d = -g with the reweighted H = sum_i w_i I and
  // g = sum_i w_i (x - z_i): d = -sum w_i (x - z_i) / ((1 + lambda) sum w_i).
  const double lambda = 0.5;
  for (const char* loss : {"huber:1", "cauchy:1", "gm:2", "dcs:1", "tukey:4"}) {
    RobustPoint p = MakeRobustPoint(loss);
    const Vec2 by_hand = ReweightedStepByHand(p, lambda);
    SolverOptions o;
    o.algorithm = Algorithm::kLevenbergMarquardt;
    o.lm.initial_lambda = lambda;
    o.max_iterations = 1;
    std::vector<IterationSummary> its;
    o.callback = [&its](const IterationSummary& it) { its.push_back(it); };
    const SolverSummary s = Optimize(p.graph, &p.values, o);
    ASSERT_TRUE(s.IsSolutionUsable()) << loss << ": " << s.FullReport();
    ASSERT_FALSE(its.empty()) << loss;
    ASSERT_TRUE(its.back().accepted) << loss << ": the damped step raised the robust cost";
    EXPECT_EQ(its.back().lambda, lambda) << loss;
    EXPECT_LT((p.values.At<Vec2>(1) - by_hand).norm(), 1e-12)
        << loss << ": solver " << p.values.At<Vec2>(1).transpose() << ", by hand " << by_hand.transpose();
  }
}

class RobustSolveEveryAlgorithm : public ::testing::TestWithParam<const char*> {};

TEST_P(RobustSolveEveryAlgorithm, ReachesAStationaryPointOfTheRobustCostNearTheInliers) {
  for (const char* loss : {"huber:1", "cauchy:1", "dcs:1"}) {
    RobustPoint p = MakeRobustPoint(loss);
    SolverOptions o;
    ASSERT_TRUE(FromString(GetParam(), &o.algorithm));
    o.function_tolerance = 1e-14;
    o.max_iterations = 200;
    const SolverSummary s = Optimize(p.graph, &p.values, o);
    ASSERT_TRUE(s.IsSolutionUsable()) << loss << ": " << s.FullReport();
    const Vec2 x = p.values.At<Vec2>(1);
    // A stationary point of sum rho (the least-squares answer, the mean (2.07, 1.63), is not).
    EXPECT_LT(CostGradient(p.graph, x).norm(), 1e-5) << loss << " at " << x.transpose();
    EXPECT_LT(x.norm(), 0.8) << loss << ": the outlier pulled the point to " << x.transpose();
    // The summary reports the robust cost and chi2 apart.
    EXPECT_NEAR(s.final_cost, p.graph.Cost(p.values), 1e-12 * s.final_cost) << loss;
    EXPECT_NEAR(s.final_chi2, p.graph.Chi2(p.values), 1e-12 * s.final_chi2) << loss;
    EXPECT_LT(s.final_cost, 0.5 * s.final_chi2) << loss << ": the outlier should cost far less than its chi2";
    EXPECT_LT(s.final_cost, s.initial_cost) << loss;
  }
}

INSTANTIATE_TEST_SUITE_P(Solvers, RobustSolveEveryAlgorithm, ::testing::Values("gn", "lm", "dogleg", "ceres"));

TEST(RobustSolveTest, CeresAndTheNativeSolverReachTheSameRobustOptimum) {
  for (const char* loss : {"huber:1", "cauchy:1", "gm:2", "dcs:1"}) {
    RobustPoint native = MakeRobustPoint(loss), ceres = MakeRobustPoint(loss);
    SolverOptions o;
    o.function_tolerance = 1e-14;
    o.max_iterations = 200;
    ASSERT_TRUE(Optimize(native.graph, &native.values, o).IsSolutionUsable()) << loss;
    o.algorithm = Algorithm::kCeres;
    const SolverSummary s = Optimize(ceres.graph, &ceres.values, o);
    ASSERT_TRUE(s.IsSolutionUsable()) << loss << ": " << s.FullReport();
    EXPECT_LT((native.values.At<Vec2>(1) - ceres.values.At<Vec2>(1)).norm(), 1e-6)
        << loss << ": native " << native.values.At<Vec2>(1).transpose() << ", Ceres "
        << ceres.values.At<Vec2>(1).transpose();
  }
}

TEST(RobustSolveTest, WithoutALossCostAndChi2AreOne) {
  Problem9 p = Make();
  const SolverSummary s = Optimize(p.graph, &p.values, SolverOptions());
  ASSERT_TRUE(s.IsSolutionUsable()) << s.FullReport();
  EXPECT_EQ(s.initial_cost, s.initial_chi2);
  EXPECT_EQ(s.final_cost, s.final_chi2);
}

}  // namespace
}  // namespace tether
