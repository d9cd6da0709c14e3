#pragma once
// The right-invariant EKF for SLAM (after Barrau and Bonnabel's invariant EKF): the same
// problem as EkfSlam (landmark_filter.h), with the robot and the landmarks taken as one element
// X = (R, p, l_1, ..., l_n) of a Lie group and the error defined on it, e = X_hat X^-1, rather
// than as the difference of the parameters. Its error coordinates are
//   xi = (xi_p, xi_theta, xi_l1, ...),  theta_hat - theta = xi_theta,
//   p_hat - R_e p = xi_p,  l_hat - R_e l = xi_l  (R_e = R_hat R^T; to first order).
// With it the linearised problem keeps the true one's unobservable directions (a rotation and
// translation of everything) wherever it is linearised, which is what makes the plain EKF
// overconfident (docs/front_ends.md, "Consistency"):
// - Predict: the odometry composes on the right, X' = X Gamma(u), so the error does not change
//   (the Jacobian is the identity) and the control noise enters through the adjoint of the
//   new estimate: xi_p += R zeta_p - zeta_theta J p, xi_theta += zeta_theta,
//   xi_l += -zeta_theta J l (J the 90-degree rotation, zeta the increment's noise in the robot's
//   frame after the move).
// - Correct: z = h(R^T (l - p)) depends on the error only through xi_l - xi_p, so
//   H = [D R^T, 0, ..., -D R^T, ...] (D the Jacobian of (range, bearing) in the robot's frame)
//   has no heading column; the correction xi_hat = K nu is applied as X <- Exp(-xi_hat) X.
//   Each correction is iterated (options.update_iterations Gauss-Newton steps, relinearising
//   at the corrected estimate; 1: the plain update).
// - A new landmark: l = p + R y(z), so xi_l = xi_p + R G_z v: its error copies the robot
//   position's (cross-covariances included) plus the measurement's.
// cov() and pose_cov() give the covariance of the parameters (x, y, theta, l), as the other
// filters do: M Sigma_xi M^T with M the first-order map from xi to the parameters' error.
#include "tether/frontends/ekf/landmark_filter.h"

namespace tether {
namespace ekf {

class InvariantEkfSlam : public LandmarkFilter {
 public:
  InvariantEkfSlam(const SE2d& start, const Eigen::Matrix3d& start_cov, const FilterOptions& options = {});

  /// The covariance of the invariant error xi (x, y, theta, landmarks, as the state).
  const Eigen::MatrixXd& invariant_cov() const { return xi_cov_; }

 protected:
  void PredictChecked(const odometry::Control& u, double dt) override;
  void Correct(int i, const Eigen::Vector2d& z) override;
  void AddLandmark(const Eigen::Vector2d& z) override;
  std::vector<double> Distances(const Eigen::Vector2d& z) const override;

 private:
  // H (the robot's position and landmark i's columns: 2x2 each, the same up to sign) and the
  // predicted observation at the current mean.
  Eigen::Vector2d Predicted(int i, Eigen::Matrix2d* d_position) const;
  // cov_ <- M xi_cov_ M^T.
  void RefreshParameterCovariance();

  Eigen::MatrixXd xi_cov_;
};

}  // namespace ekf
}  // namespace tether
