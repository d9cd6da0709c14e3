#pragma once
// The unscented transform (Julier and Uhlmann; the scaled form of Wan and van der Merwe), and
// the Kalman predict and update steps built on it. UKF-SLAM (ukf_slam.h) is these steps with
// angle-aware differences; the test on a linear-Gaussian system checks them against the
// Kalman filter.
//
// For x ~ N(m, P) of size n: lambda = alpha^2 (n + kappa) - n; sigma points m and
// m +/- (sqrt((n + lambda) P))_i (columns of the Cholesky factor), i = 1..n; weights
// W_m0 = lambda / (n + lambda), W_c0 = W_m0 + 1 - alpha^2 + beta, W_i = 1 / (2 (n + lambda)).
#include <Eigen/Core>
#include <functional>
#include <string>

namespace tether {
namespace ekf {

struct UnscentedParams {
  /// Spread of the sigma points (0 < alpha <= 1): at alpha sqrt(n + kappa) standard
  /// deviations. Default 0.5 (UKF-SLAM on the thesis's worlds, benchmarks/RESULTS.md: 1 puts
  /// the points of a 45-dimensional state 6.7 standard deviations out, where the heading's
  /// nonlinearity is far from what one step sees; 0.05 and below make W_0 so negative that the
  /// covariance loses definiteness on some runs).
  double alpha = 0.5;
  /// Prior knowledge of the distribution (2 is optimal for a Gaussian). Default 2.
  double beta = 2;
  /// Secondary scaling. Default 0.
  double kappa = 0;
  /// True where n + lambda > 0 for every n >= 1 and alpha > 0; otherwise says why.
  bool IsValid(std::string* why) const;
};

/// a - b in the space of a vector (for example with an angle wrapped); empty: plain difference.
using Difference = std::function<Eigen::VectorXd(const Eigen::VectorXd& a, const Eigen::VectorXd& b)>;
using Function = std::function<Eigen::VectorXd(const Eigen::VectorXd& x)>;

/// y = f(x) for x ~ N(mean, cov): the mean and covariance of y and the cross-covariance
/// E[(x - mean)(y - y_mean)^T]. The mean is taken as y_0 + sum_i W_m,i (y_i - y_0) with
/// y_diff, so an angle averages correctly across +-pi. Throws InvalidArgument where cov is not
/// positive definite (its Cholesky factor fails) or the parameters are invalid.
struct Transformed {
  Eigen::VectorXd mean;
  Eigen::MatrixXd cov;
  Eigen::MatrixXd cross;
};
Transformed UnscentedTransform(const Eigen::VectorXd& mean, const Eigen::MatrixXd& cov, const Function& f,
                               const UnscentedParams& params, const Difference& x_diff = nullptr,
                               const Difference& y_diff = nullptr);

/// Kalman predict through f with additive noise q: mean <- E[f(x)], cov <- Cov[f(x)] + q.
void UnscentedPredict(Eigen::VectorXd* mean, Eigen::MatrixXd* cov, const Function& f, const Eigen::MatrixXd& q,
                      const UnscentedParams& params, const Difference& x_diff = nullptr);

/// Kalman update with z = h(x) + v, v ~ N(0, r): S = Cov[h(x)] + r, K = C S^-1 (C the
/// cross-covariance), mean <- mean + K (z - zhat), cov <- cov - K S K^T (a caller with an
/// angle in the state wraps it afterwards). Returns the innovation z - zhat.
Eigen::VectorXd UnscentedUpdate(Eigen::VectorXd* mean, Eigen::MatrixXd* cov, const Function& h,
                                const Eigen::VectorXd& z, const Eigen::MatrixXd& r, const UnscentedParams& params,
                                const Difference& x_diff = nullptr, const Difference& z_diff = nullptr);

}  // namespace ekf
}  // namespace tether
