#include "tether/factors/pose_point.h"

namespace tether {

bool PosePoint2::Evaluate(const double* const* params, double* error, double* const* jacobians) const {
  const double* x = params[0];
  const double* l = params[1];
  const double c = std::cos(x[2]), s = std::sin(x[2]);
  const double dx = l[0] - x[0], dy = l[1] - x[1];
  const double px = c * dx + s * dy, py = -s * dx + c * dy;
  error[0] = px - z_.x();
  error[1] = py - z_.y();
  if (jacobians == nullptr) return true;
  if (double* J = jacobians[0]) {
    J[0] = -1, J[1] = 0, J[2] = py;
    J[3] = 0, J[4] = -1, J[5] = -px;
  }
  if (double* J = jacobians[1]) {
    J[0] = c, J[1] = s;
    J[2] = -s, J[3] = c;
  }
  return true;
}

bool PosePoint2::Predict(std::size_t known, const double* kp, std::size_t unknown, double* out) const {
  if (known != 0 || unknown != 1) return false;  // a pose cannot be placed from one point
  const Eigen::Vector2d p = SE2d::FromParams(kp) * z_;
  out[0] = p.x(), out[1] = p.y();
  return true;
}

bool PosePoint3::Evaluate(const double* const* params, double* error, double* const* jacobians) const {
  const SE3d x = SE3d::FromParams(params[0]);
  const Eigen::Vector3d l(params[1]);
  const Eigen::Matrix3d Rt = x.rotation().matrix().transpose();
  const Eigen::Vector3d p = Rt * (l - x.translation());
  for (int i = 0; i < 3; ++i) error[i] = p[i] - z_[i];
  if (jacobians == nullptr) return true;
  using RowMajor36 = Eigen::Matrix<double, 3, 6, Eigen::RowMajor>;
  using RowMajor33 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
  if (jacobians[0] != nullptr) {
    Eigen::Map<RowMajor36> J(jacobians[0]);
    J.leftCols<3>() = -Eigen::Matrix3d::Identity();
    J.rightCols<3>() = Skew<double>(p);
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<RowMajor33> J(jacobians[1]);
    J = Rt;
  }
  return true;
}

bool PosePoint3::Predict(std::size_t known, const double* kp, std::size_t unknown, double* out) const {
  if (known != 0 || unknown != 1) return false;
  const Eigen::Vector3d p = SE3d::FromParams(kp) * z_;
  out[0] = p.x(), out[1] = p.y(), out[2] = p.z();
  return true;
}

}  // namespace tether
