#include "tether/frontends/ekf/consistency.h"

#include <Eigen/Cholesky>
#include <string>

#include "tether/core/error.h"
#include "tether/core/robust_kernels.h"

namespace tether {
namespace ekf {

double Nees(const SE2d& estimate, const Eigen::Matrix3d& cov, const SE2d& truth) {
  const Eigen::Vector3d e(estimate.x() - truth.x(), estimate.y() - truth.y(),
                          WrapAngle(estimate.theta() - truth.theta()));
  return e.dot(cov.ldlt().solve(e));
}

double TangentNees(const SE2d& estimate, const Eigen::Matrix3d& cov, const SE2d& truth) {
  const Eigen::Vector3d e = estimate.Local(truth);
  return e.dot(cov.ldlt().solve(e));
}

NeesInterval AverageNeesInterval(int runs, int dof, double confidence) {
  if (runs < 1 || dof < 1 || !(confidence > 0 && confidence < 1)) {
    throw InvalidArgument("AverageNeesInterval: needs runs >= 1, dof >= 1 and a confidence in (0, 1) (got " +
                          std::to_string(runs) + ", " + std::to_string(dof) + ", " + std::to_string(confidence) + ")");
  }
  const int k = runs * dof;
  const double tail = 0.5 * (1 - confidence);
  return NeesInterval{Chi2Quantile(k, tail) / runs, Chi2Quantile(k, 1 - tail) / runs};
}

}  // namespace ekf
}  // namespace tether
