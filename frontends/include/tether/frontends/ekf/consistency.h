#pragma once
// Consistency of a pose estimate with its covariance: the normalised estimation error squared
// (NEES) e^T P^-1 e, and the interval its average over Monte Carlo runs falls in where the
// estimator is consistent (e Gaussian with covariance P): the sum over N runs of a d-dimensional
// error is then chi-square with N d degrees of freedom.
#include <Eigen/Core>

#include "tether/core/se2.h"

namespace tether {
namespace ekf {

/// NEES of an estimate (x, y, theta) whose covariance `cov` is in those parameters (a filter's),
/// against the truth: e = (x - x_t, y - y_t, wrap(theta - theta_t)). Infinity where `cov` is not
/// positive definite and e is not zero (a particle set whose weight one particle holds); 0 where
/// e is zero. The same for TangentNees.
double Nees(const SE2d& estimate, const Eigen::Matrix3d& cov, const SE2d& truth);
/// NEES for a covariance in the SE2 tangent at the estimate (a smoother's marginal):
/// e = estimate.Local(truth).
double TangentNees(const SE2d& estimate, const Eigen::Matrix3d& cov, const SE2d& truth);

struct NeesInterval {
  double lower = 0;
  double upper = 0;
  bool Contains(double average) const { return average > lower && average < upper; }
};

/// The p quantile of the chi-square distribution with k degrees of freedom, exact (bisection on
/// the regularised incomplete gamma function; Chi2Quantile in core is Wilson and Hilferty's
/// approximation, poor in the lower tail for few degrees of freedom). Throws InvalidArgument
/// for k < 1 or p outside (0, 1).
double ChiSquareQuantile(int k, double p);

/// The two-sided `confidence` interval of the average NEES over `runs` runs of a
/// `dof`-dimensional error (chi-square quantiles (1 -+ confidence) / 2 with runs * dof degrees
/// of freedom, divided by runs): [2.36, 3.72] for 50 runs of a planar pose at 0.95. Throws
/// InvalidArgument for runs or dof below 1 or a confidence outside (0, 1).
NeesInterval AverageNeesInterval(int runs, int dof, double confidence = 0.95);

}  // namespace ekf
}  // namespace tether
