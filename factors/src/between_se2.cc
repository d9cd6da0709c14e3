#include "tether/factors/between_se2.h"

#include "relative_pose_error.h"

namespace tether {

// With Xi perturbed as (ti + Ri dti, thi + dthi) and Xj likewise, and D = Xi^-1 Xj:
//   dD.t/ddti = -I, dD.t/ddthi = (D.y, -D.x), dD.t/ddtj = R(D.theta), dD.theta/ddth = -1 / +1;
// the error's translation is Rz^T (D.t - z.t), its angle wrap(D.theta - z.theta).
void EvaluateSE2Relative(const SE2d& z_, double cz, double sz, const double* a, const double* b, double* error,
                         double* jac_i, double* jac_j) {
  const double ci = std::cos(a[2]), si = std::sin(a[2]);
  const double dx = b[0] - a[0], dy = b[1] - a[1];
  const double Dx = ci * dx + si * dy;
  const double Dy = -si * dx + ci * dy;
  const double Dth = b[2] - a[2];
  const double ex = Dx - z_.x(), ey = Dy - z_.y();
  error[0] = cz * ex + sz * ey;
  error[1] = -sz * ex + cz * ey;
  error[2] = WrapAngle(Dth - z_.theta());
  if (double* J = jac_i) {
    // Rz^T * [-I | (Dy, -Dx)]
    J[0] = -cz, J[1] = -sz, J[2] = cz * Dy - sz * Dx;
    J[3] = sz, J[4] = -cz, J[5] = -sz * Dy - cz * Dx;
    J[6] = 0, J[7] = 0, J[8] = -1;
  }
  if (double* J = jac_j) {
    // Rz^T * R(Dth)
    const double c = std::cos(Dth - z_.theta()), s = std::sin(Dth - z_.theta());
    J[0] = c, J[1] = -s, J[2] = 0;
    J[3] = s, J[4] = c, J[5] = 0;
    J[6] = 0, J[7] = 0, J[8] = 1;
  }
}

bool BetweenSE2::Evaluate(const double* const* params, double* error, double* const* jacobians) const {
  EvaluateSE2Relative(z_, cz_, sz_, params[0], params[1], error, jacobians ? jacobians[0] : nullptr,
                      jacobians ? jacobians[1] : nullptr);
  return true;
}

bool BetweenSE2::Predict(std::size_t known, const double* kp, std::size_t unknown, double* out) const {
  if (known == unknown || known > 1 || unknown > 1) return false;
  const SE2d x = SE2d::FromParams(kp);
  (known == 0 ? x * z_ : x * z_.Inverse()).ToParams(out);
  return true;
}

}  // namespace tether
