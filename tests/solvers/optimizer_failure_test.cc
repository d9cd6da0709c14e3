// Failure paths of the solver: malformed factors, non-finite Jacobians, factors that throw,
// singular systems under QR. None may crash, report "converged" on bad numbers, or leave
// non-finite values.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "tether/core/autodiff_factor.h"
#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/prior.h"
#include "tether/solvers/optimizer.h"

namespace tether {
namespace {

// e = (10 (y + 0.5), x - 1 + acos(min(1, 1 - y))): finite everywhere, but its Jacobian is
// NaN where y <= 0 (acos' at 1 times a zero derivative). The minimum (x = 1 + acos(1.5)...)
// lies at y = -0.5, inside the bad region.
class NanJacobianFactor : public AutoDiffFactor<NanJacobianFactor, 2, Eigen::Vector2d> {
 public:
  explicit NanJacobianFactor(Key k) : AutoDiffFactor({k}, SqrtInformation::Identity(2)) {}
  static constexpr const char* kTypeName = "NanJacobian";
  template <typename T>
  bool operator()(const T* const* p, T* e) const {
    using std::acos;
    T a = T(1) - p[0][1];
    if (a > T(1)) a = T(1);
    e[0] = T(10) * (p[0][1] + T(0.5));
    e[1] = p[0][0] - T(1) + acos(a);
    return true;
  }
};

// Pulls a point towards (5, 5) but throws once x exceeds 2.
class ThrowingFactor : public AutoDiffFactor<ThrowingFactor, 2, Eigen::Vector2d> {
 public:
  explicit ThrowingFactor(Key k) : AutoDiffFactor({k}, SqrtInformation::Identity(2)) {}
  static constexpr const char* kTypeName = "Throwing";
  template <typename T>
  bool operator()(const T* const* p, T* e) const {
    if (p[0][0] > T(2)) throw std::runtime_error("measurement model undefined beyond x = 2");
    e[0] = p[0][0] - T(5);
    e[1] = p[0][1] - T(5);
    return true;
  }
};

bool AllFinite(const Values& v) {
  for (int t = 0; t < kNumBuiltinVarTypes; ++t)
    for (double x : v.Data(static_cast<VarType>(t)))
      if (!std::isfinite(x)) return false;
  return true;
}

TEST(OptimizerFailureTest, NoiseOfTheWrongDimensionIsInvalidInput) {
  FactorGraph g;
  g.Add(std::make_unique<BetweenSE2>(0, 1, SE2d(1, 0, 0), SqrtInformation::Identity(2)));
  Values v;
  v.Insert(0, SE2d());
  v.Insert(1, SE2d());
  const SolverSummary s = Optimize(g, &v, {});
  EXPECT_EQ(s.status, SolverStatus::kInvalidInput);
  EXPECT_NE(s.message.find("noise model of dimension 2 for an error of dimension 3"), std::string::npos) << s.message;
  EXPECT_THROW(g.Chi2(v), InvalidArgument);
}

TEST(OptimizerFailureTest, WrongNumberOfKeysIsInvalidInput) {
  Values v;
  v.Insert(1, Eigen::Vector2d(0, 0));
  // A factor whose keys do not match its types: build one through the base class.
  struct Mismatched : public Factor {
    Mismatched() : Factor({1, 2, 3}, SqrtInformation::Identity(2)) {}
    std::string type_name() const override { return "Mismatched"; }
    std::vector<VarType> variable_types() const override { return {VarType::kPoint2}; }
    bool Evaluate(const double* const*, double* e, double* const*) const override {
      e[0] = e[1] = 0;
      return true;
    }
    std::unique_ptr<Factor> Clone() const override { return std::make_unique<Mismatched>(*this); }
  };
  FactorGraph g3;
  g3.Add(std::make_unique<Mismatched>());
  const SolverSummary s = Optimize(g3, &v, {});
  EXPECT_EQ(s.status, SolverStatus::kInvalidInput);
  EXPECT_NE(s.message.find("has 3 keys but its type takes 1"), std::string::npos) << s.message;
}

TEST(OptimizerFailureTest, NonFiniteJacobianIsNeverConverged) {
  for (Algorithm a : {Algorithm::kLevenbergMarquardt, Algorithm::kGaussNewton}) {
    FactorGraph g;
    g.Add(std::make_unique<NanJacobianFactor>(1));
    Values v;
    v.Insert(1, Eigen::Vector2d(3, 1));
    SolverOptions o;
    o.algorithm = a;
    const SolverSummary s = Optimize(g, &v, o);
    EXPECT_TRUE(std::isfinite(s.final_chi2)) << ToString(a) << ": " << s.BriefReport();
    EXPECT_LE(s.final_chi2, s.initial_chi2) << ToString(a);
    EXPECT_NEAR(s.final_chi2, g.Chi2(v), 1e-9 * std::max(1.0, s.final_chi2)) << ToString(a);
    EXPECT_TRUE(AllFinite(v));
    if (a == Algorithm::kGaussNewton) {
      EXPECT_EQ(s.status, SolverStatus::kDiverged) << s.message;
    }
    // Wherever it stopped, the values it returned have a finite Jacobian (y > 0).
    EXPECT_GT(v.At<Eigen::Vector2d>(1).y(), 0.0) << ToString(a);
  }
  // A start with a non-finite Jacobian is refused outright.
  FactorGraph g;
  g.Add(std::make_unique<NanJacobianFactor>(1));
  Values v;
  v.Insert(1, Eigen::Vector2d(3, -1));
  const SolverSummary s = Optimize(g, &v, {});
  EXPECT_EQ(s.status, SolverStatus::kInvalidInput);
  EXPECT_NE(s.message.find("the Jacobian at the initial values is not finite: factor 0 (NanJacobian, keys 1) has a "
                           "non-finite Jacobian with respect to 1"),
            std::string::npos)
      << s.message;
}

// A non-finite start names the first factor at fault, its type and its keys, with every solver.
TEST(OptimizerFailureTest, ANonFiniteStartNamesTheFactorItsTypeAndKeys) {
  FactorGraph g;
  const SqrtInformation n = SqrtInformation::Identity(3);
  g.Add<BetweenSE2>(0, 1, SE2d(1, 0, 0), n);
  g.Add<BetweenSE2>(1, Symbol('x', 2), SE2d(1, 0, 0), n);
  g.Add<PriorSE2>(0, SE2d(), n);
  for (const char* algorithm : {"gn", "lm", "dogleg", "ceres"}) {
    Values v;
    v.Insert(0, SE2d());
    v.Insert(1, SE2d(1, 0, 0));
    v.Insert(Symbol('x', 2), SE2d(std::numeric_limits<double>::infinity(), 0, 0));
    SolverOptions o;
    ASSERT_TRUE(FromString(algorithm, &o.algorithm));
    const SolverSummary s = Optimize(g, &v, o);
    EXPECT_EQ(s.status, SolverStatus::kInvalidInput) << algorithm;
    EXPECT_NE(s.message.find("chi2 at the initial values is not finite: factor 1 (BetweenSE2, keys 1, x2) has a "
                             "non-finite error"),
              std::string::npos)
        << algorithm << ": " << s.message;
  }
}

TEST(OptimizerFailureTest, AFactorThatThrowsKeepsTheLastGoodValues) {
  for (Algorithm a : {Algorithm::kLevenbergMarquardt, Algorithm::kGaussNewton}) {
    FactorGraph g;
    g.Add(std::make_unique<ThrowingFactor>(1));
    Values v;
    v.Insert(1, Eigen::Vector2d(0, 0));
    SolverOptions o;
    o.algorithm = a;
    const SolverSummary s = Optimize(g, &v, o);
    EXPECT_EQ(s.status, SolverStatus::kDiverged) << ToString(a);
    EXPECT_NE(s.message.find("measurement model undefined beyond x = 2"), std::string::npos) << s.message;
    EXPECT_EQ(v.At<Eigen::Vector2d>(1), Eigen::Vector2d(0, 0)) << ToString(a);
  }
}

TEST(OptimizerFailureTest, QrDetectsRankDeficiencyOfDisconnectedLoops) {
  // Two 20-pose loops with no link between them; the second floats freely.
  FactorGraph g;
  Values v;
  const auto noise = SqrtInformation::Isotropic(3, 0.1);
  for (int loop = 0; loop < 2; ++loop) {
    for (int i = 0; i < 20; ++i) {
      const Key a = loop * 100 + i, b = loop * 100 + (i + 1) % 20;
      g.Add(std::make_unique<BetweenSE2>(a, b, SE2d(1, 0, 2 * M_PI / 20), noise));
      v.Insert(a, SE2d(std::cos(i * 0.3) * 3 + loop * 10 + 0.01 * i, std::sin(i * 0.3) * 3, i * 0.3 + 0.02));
    }
  }
  SolverOptions o;
  o.algorithm = Algorithm::kGaussNewton;
  o.linear_solver = LinearSolverType::kQR;
  const SolverSummary s = Optimize(g, &v, o);
  EXPECT_EQ(s.status, SolverStatus::kRankDeficient) << s.BriefReport() << " " << s.message;
  EXPECT_TRUE(AllFinite(v));
}

TEST(OptimizerFailureTest, EverySolverRefusesAFactorUsingOneVariableTwice) {
  FactorGraph g;
  g.Add(std::make_unique<BetweenSE2>(0, 1, SE2d(1, 0, 0), SqrtInformation::Identity(3)));
  g.Add(std::make_unique<BetweenSE2>(1, 1, SE2d(), SqrtInformation::Identity(3)));
  Values v;
  v.Insert(0, SE2d());
  v.Insert(1, SE2d(0.5, 0, 0));
  // As the file readers refuse such an edge, so does every solver, naming the factor.
  for (LinearSolverType t : {LinearSolverType::kQR, LinearSolverType::kCholmod, LinearSolverType::kEigenLDLT}) {
    SolverOptions o;
    o.linear_solver = t;
    const SolverSummary s = Optimize(g, &v, o);
    EXPECT_EQ(s.status, SolverStatus::kInvalidInput);
    EXPECT_NE(s.message.find("BetweenSE2 factor connects 1 to itself"), std::string::npos) << s.message;
    EXPECT_EQ(v.At<SE2d>(1).x(), 0.5);
  }
}

// Pulls a point towards x = 2 and stops evaluating (returns false) after `fuse` calls: a
// factor whose result is not a function of its values alone, failing part-way through.
class FailsAfterFactor : public Factor {
 public:
  FailsAfterFactor(Key k, int fuse) : Factor({k}, SqrtInformation::Identity(1)), fuse_(fuse) {}
  std::string type_name() const override { return "FailsAfter"; }
  std::vector<VarType> variable_types() const override { return {VarType::kPoint2}; }
  bool Evaluate(const double* const* p, double* e, double* const* j) const override {
    if (++calls_ > fuse_) return false;
    e[0] = p[0][0] - 2;
    if (j != nullptr && j[0] != nullptr) {
      j[0][0] = 1;
      j[0][1] = 0;
    }
    return true;
  }
  std::unique_ptr<Factor> Clone() const override { return std::make_unique<FailsAfterFactor>(*this); }

 private:
  int fuse_;
  mutable int calls_ = 0;
};

// e = y - 1 (fixes the point's other coordinate).
class YFactor : public AutoDiffFactor<YFactor, 1, Eigen::Vector2d> {
 public:
  explicit YFactor(Key k) : AutoDiffFactor({k}, SqrtInformation::Identity(1)) {}
  static constexpr const char* kTypeName = "Y";
  template <typename T>
  bool operator()(const T* const* p, T* e) const {
    e[0] = p[0][1] - T(1);
    return true;
  }
};

TEST(OptimizerFailureTest, AFactorThatStopsEvaluatingPartWayIsNamedNeverBlamedOnTheGraph) {
  // Wherever in the solve the factor stops evaluating, the solve either converged before
  // that or ends invalid-input naming it; never "rank-deficient" or a claim of convergence
  // after the failure.
  int failures = 0;
  for (int fuse = 1; fuse < 8; ++fuse) {
    for (const char* algorithm : {"lm", "gn", "dogleg"}) {
      FactorGraph g;
      g.Add(std::make_unique<FailsAfterFactor>(1, fuse));
      g.Add(std::make_unique<YFactor>(1));
      Values v;
      v.Insert(1, Eigen::Vector2d(0.3, 0.2));
      SolverOptions o;
      ASSERT_TRUE(FromString(algorithm, &o.algorithm));
      const SolverSummary s = Optimize(g, &v, o);
      if (s.status == SolverStatus::kConverged) {
        EXPECT_NEAR(v.At<Eigen::Vector2d>(1).x(), 2.0, 1e-6) << algorithm << " " << fuse << ": " << s.message;
        continue;
      }
      ++failures;
      // Gauss-Newton takes every step: there the step is blamed (diverged), and the factor named.
      EXPECT_TRUE(s.status == SolverStatus::kInvalidInput || s.status == SolverStatus::kDiverged)
          << algorithm << " " << fuse << ": " << s.message;
      EXPECT_NE(s.message.find("factor 0 (FailsAfter, keys 1)"), std::string::npos) << algorithm << " " << s.message;
      EXPECT_TRUE(AllFinite(v));
    }
  }
  EXPECT_GE(failures, 5);
}

TEST(OptimizerFailureTest, AutomaticGaugeSkipsUnusedPoses) {
  // Pose 0 exists but no factor uses it; the loop 1-2-3 must be anchored at pose 1.
  FactorGraph g;
  const auto noise = SqrtInformation::Identity(3);
  g.Add(std::make_unique<BetweenSE2>(1, 2, SE2d(1, 0, 2.0944), noise));
  g.Add(std::make_unique<BetweenSE2>(2, 3, SE2d(1, 0, 2.0944), noise));
  g.Add(std::make_unique<BetweenSE2>(3, 1, SE2d(1, 0, 2.0944), noise));
  Values v;
  v.Insert(0, SE2d());
  v.Insert(1, SE2d(0, 0, 0));
  v.Insert(2, SE2d(1, 0.1, 2.0));
  v.Insert(3, SE2d(0.5, 0.8, -2.0));
  SolverOptions o;
  o.algorithm = Algorithm::kGaussNewton;
  const SolverSummary s = Optimize(g, &v, o);
  EXPECT_EQ(s.status, SolverStatus::kConverged) << s.message;
  EXPECT_TRUE(s.gauge_fixed_automatically);
  EXPECT_EQ(s.gauge_key, 1u);
}

}  // namespace
}  // namespace tether
