#pragma once
// EKF-SLAM with range-bearing observations of point landmarks (state and data association:
// landmark_filter.h).
//
// Predict: the robot moves by the two-wheel model (odometry/diff_drive.h) with Jacobians
// A (pose) and B (controls); only the robot block and the robot-landmark cross terms change:
//   P_rr <- A P_rr A^T + B Sigma_u B^T,   P_rl <- A P_rl.
// Correct with observation z of landmark i, one landmark at a time: H is non-zero only in the
// robot's columns and landmark i's (H_r, H_l from range_bearing_model.h), so
//   P H^T = P_{:,r} H_r^T + P_{:,i} H_l^T,  S = H P H^T + R,  K = P H^T S^-1,
//   mean <- mean + K nu (nu = z - h(mean), bearing wrapped),  P <- P - K S K^T.
// A new landmark: l = g(pose, z) (the inverse observation), with G_r, G_z its Jacobians,
//   P_ll = G_r P_rr G_r^T + G_z R G_z^T,  P_l,: = G_r P_r,:  (its cross-covariances).
#include "tether/frontends/ekf/landmark_filter.h"

namespace tether {
namespace ekf {

class EkfSlam : public LandmarkFilter {
 public:
  EkfSlam(const SE2d& start, const Eigen::Matrix3d& start_cov, const FilterOptions& options = {})
      : LandmarkFilter(start, start_cov, options) {}

 protected:
  void PredictChecked(const odometry::Control& u, double dt) override;
  void Correct(int i, const Eigen::Vector2d& z) override;
  void AddLandmark(const Eigen::Vector2d& z) override;
  std::vector<double> Distances(const Eigen::Vector2d& z) const override;

 private:
  // The innovation of z against landmark i, its covariance S and P H^T.
  void Innovation(int i, const Eigen::Vector2d& z, Eigen::Vector2d* nu, Eigen::Matrix2d* s, Eigen::MatrixXd* pht) const;
};

}  // namespace ekf
}  // namespace tether
