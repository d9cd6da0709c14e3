#pragma once
// Shared test helper: compares a factor's analytic Jacobians with central differences taken
// along the same box-plus the solvers use.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tether/core/factor.h"
#include "tether/core/values.h"

namespace tether {
namespace testing {

/// Error difference that treats SE2 angle components as angles (wrapped).
inline double ErrorDifference(double a, double b, bool angle) { return angle ? WrapAngle(a - b) : a - b; }

/// Checks d error / d delta_k for every key of `f` at `values`; `angle_rows` marks error rows
/// that are angles. Returns the largest absolute difference seen.
inline double CheckJacobians(const Factor& f, const Values& values, double tolerance,
                             const std::vector<int>& angle_rows = {}) {
  const std::vector<VarType> types = f.variable_types();
  const std::vector<const double*> base = f.GatherParams(values);
  const int m = f.dim();
  std::vector<std::vector<double>> analytic(types.size());
  std::vector<double*> jptr(types.size());
  for (std::size_t k = 0; k < types.size(); ++k) {
    analytic[k].assign(m * TangentDim(types[k]), 0.0);
    jptr[k] = analytic[k].data();
  }
  std::vector<double> e0(m);
  EXPECT_TRUE(f.Evaluate(base.data(), e0.data(), jptr.data()));
  auto is_angle = [&](int r) {
    for (int a : angle_rows)
      if (a == r) return true;
    return false;
  };
  const double h = 1e-6;
  double worst = 0;
  for (std::size_t k = 0; k < types.size(); ++k) {
    const int d = TangentDim(types[k]);
    for (int c = 0; c < d; ++c) {
      std::vector<double> plus(AmbientDim(types[k])), minus(AmbientDim(types[k]));
      std::vector<double> delta(d, 0.0);
      delta[c] = h;
      RetractParams<double>(types[k], base[k], delta.data(), plus.data());
      delta[c] = -h;
      RetractParams<double>(types[k], base[k], delta.data(), minus.data());
      std::vector<const double*> pp = base, pm = base;
      pp[k] = plus.data();
      pm[k] = minus.data();
      std::vector<double> ep(m), em(m);
      EXPECT_TRUE(f.Evaluate(pp.data(), ep.data(), nullptr));
      EXPECT_TRUE(f.Evaluate(pm.data(), em.data(), nullptr));
      for (int r = 0; r < m; ++r) {
        const double numeric = ErrorDifference(ep[r], em[r], is_angle(r)) / (2 * h);
        const double diff = std::abs(numeric - analytic[k][r * d + c]);
        worst = std::max(worst, diff);
        EXPECT_NEAR(analytic[k][r * d + c], numeric, tolerance)
            << f.type_name() << ": d e[" << r << "] / d delta_" << k << "[" << c << "]";
      }
    }
  }
  return worst;
}

}  // namespace testing
}  // namespace tether
