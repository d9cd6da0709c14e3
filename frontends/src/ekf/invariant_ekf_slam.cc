#include "tether/frontends/ekf/invariant_ekf_slam.h"

#include <Eigen/Cholesky>
#include <cmath>

#include "innovation.h"
#include "tether/core/error.h"

namespace tether {
namespace ekf {

namespace {

Eigen::Matrix2d Rotation(double a) {
  Eigen::Matrix2d r;
  r << std::cos(a), -std::sin(a), std::sin(a), std::cos(a);
  return r;
}

// J v: v turned by 90 degrees.
Eigen::Vector2d Perp(const Eigen::Vector2d& v) { return Eigen::Vector2d(-v.y(), v.x()); }

// The first-order map from the invariant error to the parameters' error is M = I + m e_theta^T:
// d p = xi_p + xi_theta J p, d theta = xi_theta, d l = xi_l + xi_theta J l. This is m.
Eigen::VectorXd ErrorMapColumn(const Eigen::VectorXd& mean) {
  const Eigen::Index n = mean.size();
  Eigen::VectorXd m = Eigen::VectorXd::Zero(n);
  m.head<2>() = Perp(mean.head<2>());
  for (Eigen::Index li = 3; li + 1 < n; li += 2) m.segment<2>(li) = Perp(mean.segment<2>(li));
  return m;
}

}  // namespace

InvariantEkfSlam::InvariantEkfSlam(const SE2d& start, const Eigen::Matrix3d& start_cov, const FilterOptions& options)
    : LandmarkFilter(start, start_cov, options) {
  // Sigma_xi = M^-1 Sigma M^-T; M^-1 has the opposite theta column.
  Eigen::Matrix3d inv = Eigen::Matrix3d::Identity();
  inv.block<2, 1>(0, 2) = -Perp(mean_.head<2>());
  xi_cov_ = inv * cov_ * inv.transpose();
  xi_cov_ = 0.5 * (xi_cov_ + xi_cov_.transpose()).eval();
}

void InvariantEkfSlam::RefreshParameterCovariance() {
  xi_cov_ = 0.5 * (xi_cov_ + xi_cov_.transpose()).eval();
  // M P M^T = P + m c^T + c m^T + P_theta,theta m m^T with c = P e_theta: O(n^2).
  const Eigen::VectorXd m = ErrorMapColumn(mean_);
  const Eigen::VectorXd c = xi_cov_.col(2);
  cov_ = xi_cov_;
  cov_.noalias() += m * c.transpose();
  cov_.noalias() += c * m.transpose();
  cov_.noalias() += xi_cov_(2, 2) * m * m.transpose();
}

void InvariantEkfSlam::PredictChecked(const odometry::Control& u, double dt) {
  // The increment in the robot's frame and its covariance (x, y, theta).
  Eigen::Matrix<double, 3, 2> g;
  const Eigen::Vector3d inc = odometry::RelativeMotion(u, dt, &g);
  const Eigen::Matrix3d inc_cov = g * options_.control_cov * g.transpose();
  const SE2d moved = pose() * SE2d(inc[0], inc[1], inc[2]);
  mean_.head<3>() << moved.x(), moved.y(), moved.theta();
  // zeta = (R(inc)^T d p_inc, d theta_inc): the increment's error as a right perturbation; into
  // the invariant error through the adjoint of the new estimate.
  Eigen::Matrix3d to_zeta = Eigen::Matrix3d::Identity();
  to_zeta.topLeftCorner<2, 2>() = Rotation(inc[2]).transpose();
  const Eigen::Index n = mean_.size();
  Eigen::MatrixXd ad = Eigen::MatrixXd::Zero(n, 3);
  ad.topLeftCorner<2, 2>() = Rotation(moved.theta());
  ad.block<2, 1>(0, 2) = -Perp(moved.translation());
  ad(2, 2) = 1;
  for (Eigen::Index li = 3; li + 1 < n; li += 2) ad.block<2, 1>(li, 2) = -Perp(mean_.segment<2>(li));
  const Eigen::MatrixXd gz = ad * to_zeta;
  xi_cov_ += gz * inc_cov * gz.transpose();
  RefreshParameterCovariance();
  Tidy();
}

Eigen::Vector2d InvariantEkfSlam::Predicted(int i, Eigen::Matrix2d* d_position) const {
  const Eigen::Vector2d y = Rotation(mean_[2]).transpose() * (mean_.segment<2>(3 + 2 * i) - mean_.head<2>());
  const double r2 = y.squaredNorm(), r = std::sqrt(r2);
  if (!std::isfinite(r))
    throw InvalidArgument("invariant EKF-SLAM: the state is not finite (landmark " + std::to_string(i) + ")");
  if (!(r > 0)) throw InvalidArgument("invariant EKF-SLAM: landmark " + std::to_string(i) + " sits on the robot");
  Eigen::Matrix2d d;  // d (range, bearing) / d y
  d << y.x() / r, y.y() / r, -y.y() / r2, y.x() / r2;
  // y = y_hat - R^T (xi_l - xi_p): d z / d xi_p = D R^T.
  *d_position = d * Rotation(mean_[2]).transpose();
  return Eigen::Vector2d(r, std::atan2(y.y(), y.x()));
}

void InvariantEkfSlam::Correct(int i, const Eigen::Vector2d& z) {
  const Eigen::Index n = mean_.size(), li = 3 + 2 * i;
  const Eigen::VectorXd start = mean_;
  Eigen::VectorXd xi = Eigen::VectorXd::Zero(n);
  Eigen::MatrixXd k;
  Eigen::Matrix2d s;
  const auto apply = [&](const Eigen::VectorXd& e) {
    // X <- Exp(-e) X_start: one rigid motion of the robot and every landmark.
    const SE2d step = SE2d::Exp(-Eigen::Vector3d(e[0], e[1], e[2]));
    const SE2d robot = step * SE2d(start[0], start[1], start[2]);
    mean_.head<3>() << robot.x(), robot.y(), robot.theta();
    for (Eigen::Index lj = 3; lj + 1 < n; lj += 2) {
      const SE2d moved = SE2d::Exp(-Eigen::Vector3d(e[lj], e[lj + 1], e[2]));
      mean_.segment<2>(lj) = moved * Eigen::Vector2d(start.segment<2>(lj));
    }
  };
  try {
    for (int it = 0; it < options_.update_iterations; ++it) {
      Eigen::Matrix2d hp;
      const Eigen::Vector2d zhat = Predicted(i, &hp);
      // H = [hp (position), 0 (heading), -hp (landmark i)]: P H^T from two column blocks.
      const Eigen::MatrixXd pht = xi_cov_.leftCols<2>() * hp.transpose() - xi_cov_.middleCols<2>(li) * hp.transpose();
      s = hp * pht.topRows<2>() - hp * pht.middleRows<2>(li) + options_.measurement_cov;
      const Eigen::LLT<Eigen::Matrix2d> llt(s);
      if (llt.info() != Eigen::Success) {
        throw InvalidArgument("invariant EKF-SLAM: innovation covariance is not positive definite");
      }
      k = llt.solve(pht.transpose()).transpose();
      // Gauss-Newton: xi <- K (nu + H xi), nu at the estimate xi gives.
      const Eigen::Vector2d hxi = hp * (xi.head<2>() - xi.segment<2>(li));
      const Eigen::VectorXd next = k * (MeasurementDifference(z, zhat) + hxi);
      const double change = (next - xi).lpNorm<Eigen::Infinity>();
      xi = next;
      apply(xi);
      if (change < 1e-12) break;
    }
  } catch (...) {
    mean_ = start;  // a failed correction changes nothing
    throw;
  }
  xi_cov_ -= k * s * k.transpose();
  RefreshParameterCovariance();
}

void InvariantEkfSlam::AddLandmark(const Eigen::Vector2d& z) {
  const Eigen::Matrix2d rot = Rotation(mean_[2]);
  const Eigen::Vector2d y(z[0] * std::cos(z[1]), z[0] * std::sin(z[1]));
  Eigen::Matrix2d gz;  // d y / d z
  gz << std::cos(z[1]), -z[0] * std::sin(z[1]), std::sin(z[1]), z[0] * std::cos(z[1]);
  const Eigen::Index n = mean_.size();
  mean_.conservativeResize(n + 2);
  mean_.tail<2>() = mean_.head<2>() + rot * y;
  // xi_l = xi_p + R G_z v.
  const Eigen::MatrixXd cross = xi_cov_.topRows<2>();  // 2 x n
  const Eigen::Matrix2d rg = rot * gz;
  xi_cov_.conservativeResize(n + 2, n + 2);
  xi_cov_.bottomLeftCorner(2, n) = cross;
  xi_cov_.topRightCorner(n, 2) = cross.transpose();
  xi_cov_.bottomRightCorner<2, 2>() = cross.leftCols<2>() + rg * options_.measurement_cov * rg.transpose();
  RefreshParameterCovariance();
}

std::vector<double> InvariantEkfSlam::Distances(const Eigen::Vector2d& z) const {
  std::vector<double> d(static_cast<std::size_t>(landmark_count()));
  for (int i = 0; i < landmark_count(); ++i) {
    const Eigen::Index li = 3 + 2 * i;
    Eigen::Matrix2d hp;
    const Eigen::Vector2d nu = MeasurementDifference(z, Predicted(i, &hp));  // throws as Correct does
    // H P H^T over the two position blocks: hp (P_pp - P_pl - P_lp + P_ll) hp^T.
    const Eigen::Matrix2d block = xi_cov_.block<2, 2>(0, 0) - xi_cov_.block<2, 2>(0, li) - xi_cov_.block<2, 2>(li, 0) +
                                  xi_cov_.block<2, 2>(li, li);
    d[static_cast<std::size_t>(i)] = SquaredMahalanobis(nu, hp * block * hp.transpose() + options_.measurement_cov);
  }
  return d;
}

}  // namespace ekf
}  // namespace tether
