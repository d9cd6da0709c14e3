// The built-in robust losses (tether/core/robust_kernels.h): rho' and rho'' against central
// differences of rho and rho', the shared properties (rho(0) = 0, rho'(0) = 1, never above
// s, rho' in [0, 1] and not increasing), values at known points, and MakeLoss's text form.
#include "tether/core/robust_kernels.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/error.h"

namespace tether {
namespace {

struct Kernel {
  std::string spec;
  double kink;  // where rho'' jumps (no difference is taken across it); 0: nowhere
};

const Kernel kKernels[] = {
    {"huber:1.3", 1.3 * 1.3}, {"cauchy:2", 0}, {"tukey:3", 9}, {"gm:1.5", 0}, {"dcs:2", 2},
};

TEST(RobustKernels, DerivativesMatchFiniteDifferences) {
  for (const Kernel& k : kKernels) {
    const std::shared_ptr<const LossFunction> loss = MakeLoss(k.spec);
    for (double s : {1e-3, 0.1, 0.5, 1.0, 1.7, 2.5, 4.0, 8.0, 8.9, 9.5, 20.0, 100.0, 1e4}) {
      const double h = 1e-5 * std::max(1.0, s);
      if (k.kink > 0 && std::abs(s - k.kink) < 2 * h) continue;
      double at[3], up[3], down[3];
      loss->Evaluate(s, at);
      loss->Evaluate(s + h, up);
      loss->Evaluate(s - h, down);
      const double d1 = (up[0] - down[0]) / (2 * h);
      const double d2 = (up[1] - down[1]) / (2 * h);
      EXPECT_NEAR(at[1], d1, 1e-7 * std::max(1.0, std::abs(d1))) << k.spec << " at s = " << s;
      EXPECT_NEAR(at[2], d2, 1e-6 * std::max(1.0, std::abs(d2)) + 1e-9) << k.spec << " at s = " << s;
    }
  }
}

TEST(RobustKernels, BehaveLikeLeastSquaresNearZeroAndNeverCostMore) {
  for (const Kernel& k : kKernels) {
    const std::shared_ptr<const LossFunction> loss = MakeLoss(k.spec);
    double rho[3];
    loss->Evaluate(0, rho);
    EXPECT_EQ(rho[0], 0) << k.spec;
    EXPECT_DOUBLE_EQ(rho[1], 1) << k.spec;
    double previous = 1;
    for (double s = 0.01; s < 1e3; s *= 1.3) {
      loss->Evaluate(s, rho);
      EXPECT_LE(rho[0], s * (1 + 1e-15)) << k.spec << " at s = " << s;
      EXPECT_GT(rho[0], 0) << k.spec << " at s = " << s;
      EXPECT_GE(rho[1], 0) << k.spec << " at s = " << s;
      EXPECT_LE(rho[1], previous * (1 + 1e-15)) << k.spec << ": rho' grows at s = " << s;
      EXPECT_LE(rho[2], 0) << k.spec << " at s = " << s;
      previous = rho[1];
    }
    // Far out every kernel weighs an error much less than least squares does.
    loss->Evaluate(1e4, rho);
    EXPECT_LT(rho[1], 0.05) << k.spec;
  }
}

TEST(RobustKernels, ValuesAtKnownPoints) {
  double rho[3];
  HuberLoss(1).Evaluate(4, rho);  // |e| = 2 beyond delta 1: 2 * 1 * 2 - 1, weight 1 / 2
  EXPECT_DOUBLE_EQ(rho[0], 3);
  EXPECT_DOUBLE_EQ(rho[1], 0.5);
  HuberLoss(1).Evaluate(0.25, rho);  // inside: plain least squares
  EXPECT_DOUBLE_EQ(rho[0], 0.25);
  EXPECT_DOUBLE_EQ(rho[1], 1);
  CauchyLoss(1).Evaluate(std::exp(1.0) - 1, rho);  // c^2 log(1 + s / c^2) = 1
  EXPECT_DOUBLE_EQ(rho[0], 1);
  TukeyLoss(2).Evaluate(10, rho);  // beyond c^2 = 4: constant c^2 / 3, no weight
  EXPECT_DOUBLE_EQ(rho[0], 4.0 / 3);
  EXPECT_EQ(rho[1], 0);
  GemanMcClureLoss(1).Evaluate(1, rho);  // c^2 s / (c^2 + s) = 1 / 2, weight c^4 / (c^2 + s)^2
  EXPECT_DOUBLE_EQ(rho[0], 0.5);
  EXPECT_DOUBLE_EQ(rho[1], 0.25);
  // DCS: the information scaled by min(1, 2 phi / (phi + s))^2: phi 1, s 3 gives (1/2)^2.
  DcsLoss(1).Evaluate(3, rho);
  EXPECT_DOUBLE_EQ(rho[1], 0.25);
  EXPECT_DOUBLE_EQ(rho[0], 1.0 * (3 * 3 - 1) / (1 + 3));
  DcsLoss(1).Evaluate(0.5, rho);
  EXPECT_DOUBLE_EQ(rho[1], 1);
}

TEST(RobustKernels, MakeLossReadsTheTextFormAndNamesWhatIsWrong) {
  EXPECT_EQ(MakeLoss("huber:1.5")->name(), "huber:1.5");
  EXPECT_EQ(MakeLoss("cauchy")->name(), "cauchy:1");
  EXPECT_EQ(MakeLoss("dcs:0.25")->name(), "dcs:0.25");
  const struct {
    const char* spec;
    const char* says;
  } bad[] = {
      {"welsch:1", "unknown kernel 'welsch'"},
      {"huber:-1", "above 0"},
      {"huber:0", "above 0"},
      {"huber:x", "not a number"},
      {"huber:", "not a number"},
      {"tukey:nan", "above 0"},
      {"gm:1e999", "above 0"},
      {"huber:1.0junk", "not a number"},
  };
  for (const auto& b : bad) {
    try {
      MakeLoss(b.spec);
      ADD_FAILURE() << b.spec << " was accepted";
    } catch (const InvalidArgument& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(b.says), std::string::npos) << b.spec << ": " << what;
      EXPECT_NE(what.find(std::string("'") + b.spec + "'"), std::string::npos) << b.spec << ": " << what;
    }
  }
  EXPECT_THROW(HuberLoss(-2), InvalidArgument);
}

TEST(RobustKernels, Chi2QuantileWithinOnePercentOfTheTables) {
  // 0.99 and 0.95 quantiles of the chi2 distribution (standard tables).
  const struct {
    int k;
    double p, q;
  } table[] = {{1, 0.99, 6.635}, {2, 0.99, 9.210},  {3, 0.99, 11.345}, {6, 0.99, 16.812},
               {3, 0.95, 7.815}, {6, 0.95, 12.592}, {10, 0.9, 15.987}};
  for (const auto& t : table) EXPECT_NEAR(Chi2Quantile(t.k, t.p), t.q, 0.01 * t.q) << t.k << " " << t.p;
  EXPECT_LT(Chi2Quantile(3, 0.9), Chi2Quantile(3, 0.99));
}

TEST(RobustKernels, Chi2QuantileLowerTail) {
  // Lower and upper 2.5% points for the degrees of freedom of Monte Carlo NEES averages
  // (exact values from the regularised incomplete gamma function).
  const struct {
    int k;
    double p, q;
  } table[] = {{10, 0.05, 3.940},   {30, 0.025, 16.791},   {60, 0.025, 40.482},
               {60, 0.975, 83.298}, {150, 0.025, 117.985}, {150, 0.975, 185.800}};
  for (const auto& t : table) EXPECT_NEAR(Chi2Quantile(t.k, t.p), t.q, 0.005 * t.q) << t.k << " " << t.p;
  EXPECT_LT(Chi2Quantile(3, 0.025), Chi2Quantile(3, 0.5));
  EXPECT_GT(Chi2Quantile(3, 0.025), 0);
}

}  // namespace
}  // namespace tether
