#include "tether/frontends/ekf/ekf_slam.h"

#include "innovation.h"
#include "tether/core/error.h"

namespace tether {
namespace ekf {

void EkfSlam::PredictChecked(const odometry::Control& u, double dt) {
  Eigen::Matrix3d a;
  Eigen::Matrix<double, 3, 2> b;
  const SE2d moved = odometry::Move(pose(), u, dt, &a, &b);
  mean_.head<3>() << moved.x(), moved.y(), moved.theta();
  const Eigen::Index m = mean_.size() - 3;
  cov_.topLeftCorner<3, 3>() =
      a * cov_.topLeftCorner<3, 3>() * a.transpose() + b * options_.control_cov * b.transpose();
  if (m > 0) {
    const Eigen::MatrixXd rl = a * cov_.topRightCorner(3, m);
    cov_.topRightCorner(3, m) = rl;
    cov_.bottomLeftCorner(m, 3) = rl.transpose();
  }
  Tidy();
}

void EkfSlam::Innovation(int i, const Eigen::Vector2d& z, Eigen::Vector2d* nu, Eigen::Matrix2d* s,
                         Eigen::MatrixXd* pht) const {
  Eigen::Matrix<double, 2, 3> hr;
  Eigen::Matrix2d hl;
  const Eigen::Index li = 3 + 2 * i;
  const Eigen::Vector2d zhat = Observe(pose(), mean_.segment<2>(li), &hr, &hl);
  *nu = MeasurementDifference(z, zhat);
  *pht = cov_.leftCols<3>() * hr.transpose() + cov_.middleCols<2>(li) * hl.transpose();
  *s = hr * pht->topRows<3>() + hl * pht->middleRows<2>(li) + options_.measurement_cov;
}

void EkfSlam::Correct(int i, const Eigen::Vector2d& z) {
  Eigen::Vector2d nu;
  Eigen::Matrix2d s;
  Eigen::MatrixXd pht;
  Innovation(i, z, &nu, &s, &pht);
  if (!KalmanCorrect(pht, s, nu, &mean_, &cov_)) {
    throw InvalidArgument("EKF-SLAM: innovation covariance is not positive definite");
  }
}

void EkfSlam::AddLandmark(const Eigen::Vector2d& z) {
  Eigen::Matrix<double, 2, 3> gr;
  Eigen::Matrix2d gz;
  const Eigen::Vector2d l = InverseObserve(pose(), z, &gr, &gz);
  const Eigen::Index n = mean_.size();
  mean_.conservativeResize(n + 2);
  mean_.tail<2>() = l;
  const Eigen::MatrixXd cross = gr * cov_.topRows<3>();  // 2 x n
  cov_.conservativeResize(n + 2, n + 2);
  cov_.bottomLeftCorner(2, n) = cross;
  cov_.topRightCorner(n, 2) = cross.transpose();
  cov_.bottomRightCorner<2, 2>() =
      gr * cov_.topLeftCorner<3, 3>() * gr.transpose() + gz * options_.measurement_cov * gz.transpose();
}

std::vector<double> EkfSlam::Distances(const Eigen::Vector2d& z) const {
  std::vector<double> d(static_cast<std::size_t>(landmark_count()));
  for (int i = 0; i < landmark_count(); ++i) {
    Eigen::Vector2d nu;
    Eigen::Matrix2d s;
    Eigen::MatrixXd pht;
    Innovation(i, z, &nu, &s, &pht);
    d[static_cast<std::size_t>(i)] = SquaredMahalanobis(nu, s);
  }
  return d;
}

}  // namespace ekf
}  // namespace tether
