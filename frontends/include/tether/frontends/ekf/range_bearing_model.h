#pragma once
// Range-bearing observations of point landmarks in the plane, as the filters and the
// simulator use them: z = (r, phi) with d = l - t, r = |d|, phi = atan2(d_y, d_x) - theta
// (wrapped to (-pi, pi]); and the inverse, a landmark from a pose and an observation.
#include <Eigen/Core>
#include <vector>

#include "tether/core/se2.h"

namespace tether {
namespace ekf {

/// One observation: range [m] and bearing [rad], and the landmark's true identity where it is
/// known (the simulator's, for known data association and to count wrong associations; -1 where
/// there is none).
struct Observation {
  double range = 0;
  double bearing = 0;
  int id = -1;
};

/// z = h(pose, landmark); optionally the Jacobians with respect to the pose's parameters
/// (x, y, theta) (2x3) and the landmark (2x2). Throws InvalidArgument where the landmark sits on
/// the pose (range 0: the bearing is undefined).
Eigen::Vector2d Observe(const SE2d& pose, const Eigen::Vector2d& landmark,
                        Eigen::Matrix<double, 2, 3>* d_pose = nullptr, Eigen::Matrix2d* d_landmark = nullptr);

/// The landmark seen at z from the pose: t + r (cos(theta + phi), sin(theta + phi)); optionally
/// the Jacobians with respect to the pose's parameters (2x3) and to z (2x2).
Eigen::Vector2d InverseObserve(const SE2d& pose, const Eigen::Vector2d& z,
                               Eigen::Matrix<double, 2, 3>* d_pose = nullptr, Eigen::Matrix2d* d_z = nullptr);

/// z - zhat with the bearing wrapped.
Eigen::Vector2d MeasurementDifference(const Eigen::Vector2d& z, const Eigen::Vector2d& zhat);

}  // namespace ekf
}  // namespace tether
