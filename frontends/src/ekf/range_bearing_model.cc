#include "tether/frontends/ekf/range_bearing_model.h"

#include <cmath>

#include "tether/core/error.h"

namespace tether {
namespace ekf {

Eigen::Vector2d Observe(const SE2d& pose, const Eigen::Vector2d& landmark, Eigen::Matrix<double, 2, 3>* d_pose,
                        Eigen::Matrix2d* d_landmark) {
  const Eigen::Vector2d d = landmark - pose.translation();
  const double q = d.squaredNorm();
  if (!std::isfinite(q) || !std::isfinite(pose.theta())) {
    throw InvalidArgument("range-bearing observation of a pose or landmark that is not finite");
  }
  if (!(q > 0)) throw InvalidArgument("a landmark on the robot's position has no bearing (range 0)");
  const double r = std::sqrt(q);
  if (d_landmark != nullptr) *d_landmark << d.x() / r, d.y() / r, -d.y() / q, d.x() / q;
  if (d_pose != nullptr) *d_pose << -d.x() / r, -d.y() / r, 0, d.y() / q, -d.x() / q, -1;
  return Eigen::Vector2d(r, WrapAngle(std::atan2(d.y(), d.x()) - pose.theta()));
}

Eigen::Vector2d InverseObserve(const SE2d& pose, const Eigen::Vector2d& z, Eigen::Matrix<double, 2, 3>* d_pose,
                               Eigen::Matrix2d* d_z) {
  const double a = pose.theta() + z.y();
  const double c = std::cos(a), s = std::sin(a), r = z.x();
  if (d_pose != nullptr) *d_pose << 1, 0, -r * s, 0, 1, r * c;
  if (d_z != nullptr) *d_z << c, -r * s, s, r * c;
  return pose.translation() + Eigen::Vector2d(r * c, r * s);
}

Eigen::Vector2d MeasurementDifference(const Eigen::Vector2d& z, const Eigen::Vector2d& zhat) {
  return Eigen::Vector2d(z.x() - zhat.x(), WrapAngle(z.y() - zhat.y()));
}

}  // namespace ekf
}  // namespace tether
