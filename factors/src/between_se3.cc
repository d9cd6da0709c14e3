#include "tether/factors/between_se3.h"

#include "relative_pose_error.h"

namespace tether {

namespace {

// Error of E = Z^-1 * D with its derivative bookkeeping shared by BetweenSE3 and PriorSE3.
// Returns M = d vec(q_E) / d phi for a right perturbation E Exp(phi), sign-normalised.
Eigen::Matrix3d QuatVecJacobian(const Eigen::Quaterniond& q) {
  const double s = q.w() < 0 ? -1.0 : 1.0;
  return 0.5 * s * (q.w() * Eigen::Matrix3d::Identity() + Skew<double>(q.vec()));
}

void WriteQuatError(const Eigen::Quaterniond& q, double* e) {
  const double s = q.w() < 0 ? -1.0 : 1.0;
  e[3] = s * q.x();
  e[4] = s * q.y();
  e[5] = s * q.z();
}

}  // namespace

// Error of E = Z^-1 * (Xi^-1 * Xj) and its Jacobians (either may be null).
// With Xi perturbed as (ti + Ri b, Ri Exp(a)) and Xj as (tj + Rj d, Rj Exp(c)), D = Xi^-1 Xj:
//   t_D' = t_D - b + [t_D]x a + R_D d,    R_E' = R_E Exp(c - R_D^T a).
void EvaluateSE3Relative(const SE3d& z_, const SE3d& xi, const SE3d& xj, double* error, double* jac_i, double* jac_j) {
  const Eigen::Quaterniond qi_inv = xi.quaternion().conjugate();
  const Eigen::Vector3d tD = qi_inv * (xj.translation() - xi.translation());
  const Eigen::Quaterniond qD = qi_inv * xj.quaternion();
  const Eigen::Quaterniond qz_inv = z_.quaternion().conjugate();
  const Eigen::Vector3d tE = qz_inv * (tD - z_.translation());
  const Eigen::Quaterniond qE = qz_inv * qD;
  error[0] = tE.x(), error[1] = tE.y(), error[2] = tE.z();
  WriteQuatError(qE, error);
  if (jac_i == nullptr && jac_j == nullptr) return;
  const Eigen::Matrix3d RzT = qz_inv.toRotationMatrix();
  const Eigen::Matrix3d M = QuatVecJacobian(qE);
  const Eigen::Matrix3d RD = qD.toRotationMatrix();
  using RowMajor6 = Eigen::Matrix<double, 6, 6, Eigen::RowMajor>;
  if (jac_i != nullptr) {
    Eigen::Map<RowMajor6> J(jac_i);
    J.topLeftCorner<3, 3>() = -RzT;
    J.topRightCorner<3, 3>() = RzT * Skew<double>(tD);
    J.bottomLeftCorner<3, 3>().setZero();
    J.bottomRightCorner<3, 3>() = -M * RD.transpose();
  }
  if (jac_j != nullptr) {
    Eigen::Map<RowMajor6> J(jac_j);
    J.topLeftCorner<3, 3>() = RzT * RD;
    J.topRightCorner<3, 3>().setZero();
    J.bottomLeftCorner<3, 3>().setZero();
    J.bottomRightCorner<3, 3>() = M;
  }
}

bool BetweenSE3::Evaluate(const double* const* params, double* error, double* const* jacobians) const {
  EvaluateSE3Relative(z_, SE3d::FromParams(params[0]), SE3d::FromParams(params[1]), error,
                      jacobians ? jacobians[0] : nullptr, jacobians ? jacobians[1] : nullptr);
  return true;
}

std::vector<double> BetweenSE3::Measurement() const {
  std::vector<double> m(7);
  z_.ToParams(m.data());
  return m;
}

bool BetweenSE3::Predict(std::size_t known, const double* kp, std::size_t unknown, double* out) const {
  if (known == unknown || known > 1 || unknown > 1) return false;
  const SE3d x = SE3d::FromParams(kp);
  (known == 0 ? x * z_ : x * z_.Inverse()).ToParams(out);
  return true;
}

}  // namespace tether
