#pragma once
// Internal: what the landmark filters do with an innovation once they have it, however they
// got it (Jacobians in EkfSlam, sigma points in UkfSlam and UnscentedUpdate, the invariant
// error in InvariantEkfSlam): its Mahalanobis distance for data association, and the Kalman
// correction.
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <limits>

namespace tether {
namespace ekf {

/// d^2 = nu^T S^-1 nu for an innovation nu with covariance s; infinity where s is not positive
/// definite (no landmark can be matched through it).
inline double SquaredMahalanobis(const Eigen::Vector2d& nu, const Eigen::Matrix2d& s) {
  const Eigen::LLT<Eigen::Matrix2d> llt(s);
  return llt.info() == Eigen::Success ? nu.dot(llt.solve(nu)) : std::numeric_limits<double>::infinity();
}

/// The Kalman correction by an innovation nu with covariance s, given the cross-covariance of
/// the state and the predicted observation (P H^T for a linearised observation H):
///   K = cross S^-1,  mean <- mean + K nu,  cov <- cov - K S K^T.
/// False, changing nothing, where s is not positive definite. S keeps the caller's type (2x2
/// for one landmark, dynamic in the general unscented update), so the factorisation is the one
/// that type gets.
template <typename Covariance, typename Innovation>
bool KalmanCorrect(const Eigen::MatrixXd& cross, const Covariance& s, const Innovation& nu, Eigen::VectorXd* mean,
                   Eigen::MatrixXd* cov) {
  const Eigen::LLT<Covariance> llt(s);
  if (llt.info() != Eigen::Success) return false;
  const Eigen::MatrixXd k = llt.solve(cross.transpose()).transpose();
  *mean += k * nu;
  *cov -= k * s * k.transpose();
  return true;
}

}  // namespace ekf
}  // namespace tether
