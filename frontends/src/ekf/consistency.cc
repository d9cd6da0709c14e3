#include "tether/frontends/ekf/consistency.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>
#include <string>

#include "tether/core/error.h"

namespace tether {
namespace ekf {

namespace {

// e^T cov^-1 e; infinity where cov is not positive definite and e is not zero (an estimate
// that claims no uncertainty in a direction where it is wrong: a particle set whose weight one
// particle holds), 0 where e is zero.
double Normalised(const Eigen::Vector3d& e, const Eigen::Matrix3d& cov) {
  const Eigen::LLT<Eigen::Matrix3d> llt(cov);
  if (llt.info() != Eigen::Success) return e.isZero(0.0) ? 0.0 : std::numeric_limits<double>::infinity();
  const double v = e.dot(llt.solve(e));
  return std::isnan(v) ? std::numeric_limits<double>::infinity() : v;  // a covariance of 1e-294 overflows
}

}  // namespace

double Nees(const SE2d& estimate, const Eigen::Matrix3d& cov, const SE2d& truth) {
  const Eigen::Vector3d e(estimate.x() - truth.x(), estimate.y() - truth.y(),
                          WrapAngle(estimate.theta() - truth.theta()));
  return Normalised(e, cov);
}

double TangentNees(const SE2d& estimate, const Eigen::Matrix3d& cov, const SE2d& truth) {
  return Normalised(estimate.Local(truth), cov);
}

namespace {

// The regularised lower incomplete gamma function P(a, x): its series below x = a + 1, else one
// minus the continued fraction of Q (modified Lentz).
double LowerGammaP(double a, double x) {
  if (x <= 0) return 0;
  const double front = std::exp(-x + a * std::log(x) - std::lgamma(a));
  if (x < a + 1) {
    double term = 1 / a, sum = term;
    for (int n = 1; n < 100000 && term > 1e-17 * sum; ++n) {
      term *= x / (a + n);
      sum += term;
    }
    return front * sum;
  }
  const double tiny = 1e-300;
  double b = x + 1 - a, c = 1 / tiny, d = 1 / b, h = d;
  for (int n = 1; n < 100000; ++n) {
    const double an = -n * (n - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1) < 1e-16) break;
  }
  return 1 - front * h;
}

}  // namespace

double ChiSquareQuantile(int k, double p) {
  if (k < 1 || !(p > 0 && p < 1)) {
    throw InvalidArgument("ChiSquareQuantile: needs k >= 1 and p in (0, 1) (got " + std::to_string(k) + ", " +
                          std::to_string(p) + ")");
  }
  double lo = 0, hi = k + 40 * std::sqrt(2.0 * k) + 100;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (LowerGammaP(0.5 * k, 0.5 * mid) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

NeesInterval AverageNeesInterval(int runs, int dof, double confidence) {
  if (runs < 1 || dof < 1 || !(confidence > 0 && confidence < 1)) {
    throw InvalidArgument("AverageNeesInterval: needs runs >= 1, dof >= 1 and a confidence in (0, 1) (got " +
                          std::to_string(runs) + ", " + std::to_string(dof) + ", " + std::to_string(confidence) + ")");
  }
  const int k = runs * dof;
  const double tail = 0.5 * (1 - confidence);
  return NeesInterval{ChiSquareQuantile(k, tail) / runs, ChiSquareQuantile(k, 1 - tail) / runs};
}

}  // namespace ekf
}  // namespace tether
