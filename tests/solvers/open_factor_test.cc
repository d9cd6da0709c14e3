// The caps are gone: a factor with a residual of size 9 on 5 variables (autodiff through
// value types) solves with every linear solver and with Ceres, to the closed-form optimum of
// the linear least-squares problem it makes. And a factor that carries a robust loss is
// refused by name until the solvers apply losses.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "tether/core/autodiff_factor.h"
#include "tether/core/jacobian_check.h"
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

class CountingLoss : public LossFunction {
 public:
  std::string name() const override { return "test-huber"; }
  void Evaluate(double s, double rho[3]) const override { rho[0] = s, rho[1] = 1, rho[2] = 0; }
};

TEST(OpenFactorTest, AFactorWithALossIsRefusedByNameUntilSolversApplyLosses) {
  for (const char* algorithm : {"lm", "ceres"}) {
    Problem9 p = Make();
    p.graph.at(3).set_loss(std::make_shared<CountingLoss>());
    ASSERT_NE(p.graph.at(3).loss(), nullptr);
    const Values before = p.values;
    SolverOptions o;
    ASSERT_TRUE(FromString(algorithm, &o.algorithm));
    const SolverSummary s = Optimize(p.graph, &p.values, o);
    EXPECT_EQ(s.status, SolverStatus::kInvalidInput) << algorithm;
    EXPECT_NE(s.message.find("factor 3 (TestPrior3, keys 3) carries the robust loss 'test-huber'"), std::string::npos)
        << s.message;
    EXPECT_EQ(Stack(p.values), Stack(before));  // untouched
  }
}

}  // namespace
}  // namespace tether
