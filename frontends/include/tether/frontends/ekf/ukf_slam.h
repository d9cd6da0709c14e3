#pragma once
// UKF-SLAM: the problem of EKF-SLAM (landmark_filter.h) with sigma points
// (unscented_transform.h) in place of Jacobians.
//
// Predict: the state is augmented with the control error, [x; e_u] ~ N([mean; 0],
// diag(P, Sigma_u)), and every sigma point moved by the two-wheel model with the control
// u + e_u; mean and covariance of the images (theta averaged with wrapped differences) are the
// prediction, cross-covariances to the landmarks included.
// Correct with observation z of landmark i: the unscented transform of h_i over the whole state
// gives zhat, S (plus R) and the cross-covariance C; K = C S^-1.
// A new landmark: the state is augmented with the observation error, [x; v] ~ N([mean; 0],
// diag(P, R)), and the transform of (x, g(pose, z + v)) gives the landmark's mean, covariance and
// its cross-covariances with everything (not set to zero).
// Square roots: Cholesky (LLT); where the covariance is only semi-definite (a start known
// exactly, a noise-free control) the pivoted LDL^T factor with its negative rounding clamped to 0.
#include "tether/frontends/ekf/landmark_filter.h"

namespace tether {
namespace ekf {

class UkfSlam : public LandmarkFilter {
 public:
  UkfSlam(const SE2d& start, const Eigen::Matrix3d& start_cov, const FilterOptions& options = {})
      : LandmarkFilter(start, start_cov, options) {}

 protected:
  void PredictChecked(const odometry::Control& u, double dt) override;
  void Correct(int i, const Eigen::Vector2d& z) override;
  void AddLandmark(const Eigen::Vector2d& z) override;
  std::vector<double> Distances(const Eigen::Vector2d& z) const override;
};

}  // namespace ekf
}  // namespace tether
