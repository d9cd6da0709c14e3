#pragma once
// The two-wheel (differential-drive) motion model.
//
// Controls: forward speed v and turn rate w, from wheel speeds v = (v_l + v_r) / 2,
// w = (v_r - v_l) / D (D the wheel base), or from encoder ticks over an interval. Over a time
// step dt the robot follows an arc; with a = w dt the exact update is
//
//   x' = x - (v/w) sin(theta) + (v/w) sin(theta + a)
//   y' = y + (v/w) cos(theta) - (v/w) cos(theta + a)
//   theta' = theta + a,
//
// written here as the relative motion in the robot's frame,
//
//   delta = (v dt sin(a)/a,  v dt (1 - cos a)/a,  a),
//
// composed onto the pose. sin(a)/a and (1 - cos a)/a (and their derivatives) are taken from
// their Taylor series where |a| < 1e-3, so the straight line (w = 0) is the smooth limit of the
// arc: no division by w anywhere, exact to the last bits at w = 0 and w = 1e-12.
//
// Noise: the controls carry a Gaussian error with covariance Sigma_u (2x2, on (v, w)). It
// reaches a relative pose through the Jacobian G = d delta / d(v, w): Sigma_delta = G Sigma_u
// G^T. That matrix has rank 2 (a wheeled robot does not slip sideways in this model), so a
// pose-pose factor adds a small floor (OdometryNoise::floor_sigma) on its diagonal to have an
// information matrix and covers the second-order terms the Jacobian leaves out.
#include <Eigen/Core>

#include "tether/core/se2.h"

namespace tether {
namespace odometry {

/// Forward speed [m/s] and turn rate [rad/s].
struct Control {
  double v = 0;
  double w = 0;
};

/// v = (v_l + v_r) / 2, w = (v_r - v_l) / D. Throws InvalidArgument unless D > 0 and finite.
Control FromWheelSpeeds(double v_left, double v_right, double wheel_base);

/// The control that moves the wheels by the encoder counts over dt seconds (meters_per_tick:
/// wheel circumference / ticks per revolution). Throws InvalidArgument unless dt,
/// meters_per_tick and wheel_base are positive and finite.
Control FromTicks(long long ticks_left, long long ticks_right, double meters_per_tick, double wheel_base, double dt);

/// Sigma_u of (v, w) from independent wheel-speed errors (std per wheel, m/s), through the
/// Jacobian of (v, w) with respect to (v_l, v_r).
Eigen::Matrix2d ControlCovarianceFromWheels(double sigma_left, double sigma_right, double wheel_base);

/// The relative motion over dt in the robot's frame, (dx, dy, dtheta); optionally its
/// Jacobian with respect to (v, w) (3x2).
Eigen::Vector3d RelativeMotion(const Control& u, double dt, Eigen::Matrix<double, 3, 2>* d_control = nullptr);

/// The pose after dt: pose composed with RelativeMotion. Optionally the Jacobians of the
/// result's parameters (x, y, theta) with respect to the pose's parameters (3x3, "A") and to
/// the controls (3x2, "B"), both in world coordinates, as the filters use them.
SE2d Move(const SE2d& pose, const Control& u, double dt, Eigen::Matrix3d* d_pose = nullptr,
          Eigen::Matrix<double, 3, 2>* d_control = nullptr);

/// The control that moves a robot from `from` to `to` along one arc in dt seconds (dt > 0):
/// w = dtheta / dt, and v the arc's length over dt, negative where the robot went backwards.
/// A sideways part of the motion, which no arc has, is left out: the arc runs through the
/// chord's length with the step's heading change. Throws InvalidArgument unless dt is positive
/// and finite.
Control ControlBetween(const SE2d& from, const SE2d& to, double dt);

/// True for a symmetric, finite, positive semi-definite covariance of (v, w).
bool IsControlCovariance(const Eigen::Matrix2d& c);

/// Control noise and the floor of a relative pose's covariance.
struct OdometryNoise {
  /// Covariance of (v, w). Default: the standard deviations 0.1 m/s and pi/18 rad/s.
  Eigen::Matrix2d control = Eigen::Vector2d(0.1 * 0.1, 0.17453292519943295 * 0.17453292519943295).asDiagonal();
  /// Standard deviation added on each diagonal entry of a relative pose's covariance (m, m,
  /// rad), once per pose-pose factor, so that the factor has an information matrix and covers
  /// what the first-order propagation leaves out (the motion is curved in the controls).
  /// Default 0.03: at the thesis's noise and its double, each odometry factor's whitened error
  /// at the truth is then 1.9 and 3.0 on average (its dimension is 3); with 1e-3 it was 61 and
  /// 934 (docs/front_ends.md).
  double floor_sigma = 0.03;
};

/// Accumulates the controls between two poses of the graph: the relative pose from the first
/// to the current one, in the first pose's frame, and its covariance (propagated step by step:
/// Sigma <- F Sigma F^T + G Sigma_u G^T, F the Jacobian of the composition with respect to the
/// accumulated relative pose).
class MotionIntegrator {
 public:
  explicit MotionIntegrator(const OdometryNoise& noise = {});
  /// Adds one control over dt seconds. Throws InvalidArgument for dt <= 0 or non-finite input.
  void Add(const Control& u, double dt);
  /// Adds a measured motion over dt seconds (a wheel odometry's pose change, in the robot's
  /// frame at its start): composed exactly, with the covariance the control that makes it
  /// along an arc (ControlBetween) propagates. Throws InvalidArgument as Add does.
  void AddMotion(const SE2d& delta, double dt);
  /// The relative pose since the last Reset (identity before any Add).
  const SE2d& relative() const { return relative_; }
  /// Its covariance (rank 2 after one step, without the floor).
  const Eigen::Matrix3d& covariance() const { return covariance_; }
  /// The information of the pose-pose factor (BetweenSE2) whose measurement is relative():
  /// the inverse of (covariance + floor^2 I), turned into the factor's error coordinates (its
  /// translation is expressed in the measured relative pose's frame: J C^-1 J^T with
  /// J = diag(R(theta)^T, 1).
  Eigen::Matrix3d Information() const;
  int steps() const { return steps_; }
  void Reset();

 private:
  OdometryNoise noise_;
  SE2d relative_;
  Eigen::Matrix3d covariance_ = Eigen::Matrix3d::Zero();
  int steps_ = 0;
};

}  // namespace odometry
}  // namespace tether
