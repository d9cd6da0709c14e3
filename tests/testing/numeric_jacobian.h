#pragma once
// Shared test helper: the Jacobian of a function of a vector by central differences (step
// 1e-6), with one output entry (an angle) wrapped to (-pi, pi] before dividing; -1: none.
#include <Eigen/Core>
#include <functional>

#include "tether/core/so2.h"

namespace tether {
namespace testing {

inline Eigen::MatrixXd NumericJacobian(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f,
                                       const Eigen::VectorXd& x, int angle_row) {
  const Eigen::VectorXd y0 = f(x);
  Eigen::MatrixXd j(y0.size(), x.size());
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const double h = 1e-6;
    Eigen::VectorXd a = x, b = x;
    a[i] += h;
    b[i] -= h;
    Eigen::VectorXd d = f(a) - f(b);
    if (angle_row >= 0) d[angle_row] = WrapAngle(d[angle_row]);
    j.col(i) = d / (2 * h);
  }
  return j;
}

}  // namespace testing
}  // namespace tether
