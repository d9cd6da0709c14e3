#include "tether/frontends/odometry/diff_drive.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <string>

#include "tether/core/error.h"

namespace tether {
namespace odometry {
namespace {

bool PositiveFinite(double x) { return std::isfinite(x) && x > 0; }

}  // namespace

bool IsControlCovariance(const Eigen::Matrix2d& c) {
  if (!c.allFinite() || c(0, 1) != c(1, 0)) return false;
  // Semi-definite: both diagonal entries and the determinant not negative.
  return c(0, 0) >= 0 && c(1, 1) >= 0 && c(0, 0) * c(1, 1) - c(0, 1) * c(1, 0) >= 0;
}

namespace {

// sin(a)/a, (1 - cos a)/a and their derivatives; Taylor series near 0 (the next terms are
// below 1e-20 there, far under a double's resolution of the leading 1).
struct ArcCoefficients {
  double f1, f2, df1, df2;
};

ArcCoefficients Arc(double a) {
  ArcCoefficients c;
  if (std::abs(a) < 1e-3) {
    const double a2 = a * a;
    c.f1 = 1 - a2 / 6 + a2 * a2 / 120;
    c.f2 = a / 2 - a * a2 / 24 + a * a2 * a2 / 720;
    c.df1 = -a / 3 + a * a2 / 30;
    c.df2 = 0.5 - a2 / 8 + a2 * a2 / 144;
  } else {
    const double s = std::sin(a), co = std::cos(a);
    const double h = std::sin(a / 2), one_minus_cos = 2 * h * h;  // 1 - cos a without cancellation
    c.f1 = s / a;
    c.f2 = one_minus_cos / a;
    c.df1 = (a * co - s) / (a * a);
    c.df2 = (a * s - one_minus_cos) / (a * a);
  }
  return c;
}

}  // namespace

Control FromWheelSpeeds(double v_left, double v_right, double wheel_base) {
  if (!PositiveFinite(wheel_base)) {
    throw InvalidArgument("wheel base must be positive and finite, got " + std::to_string(wheel_base));
  }
  return Control{(v_left + v_right) / 2, (v_right - v_left) / wheel_base};
}

Control FromTicks(long long ticks_left, long long ticks_right, double meters_per_tick, double wheel_base, double dt) {
  if (!PositiveFinite(meters_per_tick) || !PositiveFinite(dt)) {
    throw InvalidArgument("encoder ticks need positive, finite meters_per_tick and dt (got " +
                          std::to_string(meters_per_tick) + " and " + std::to_string(dt) + ")");
  }
  const double left = static_cast<double>(ticks_left) * meters_per_tick / dt;
  const double right = static_cast<double>(ticks_right) * meters_per_tick / dt;
  return FromWheelSpeeds(left, right, wheel_base);
}

Eigen::Matrix2d ControlCovarianceFromWheels(double sigma_left, double sigma_right, double wheel_base) {
  if (!PositiveFinite(wheel_base)) {
    throw InvalidArgument("wheel base must be positive and finite, got " + std::to_string(wheel_base));
  }
  Eigen::Matrix2d j;  // d(v, w) / d(v_l, v_r)
  j << 0.5, 0.5, -1 / wheel_base, 1 / wheel_base;
  const Eigen::Vector2d var(sigma_left * sigma_left, sigma_right * sigma_right);
  return j * var.asDiagonal() * j.transpose();
}

Eigen::Vector3d RelativeMotion(const Control& u, double dt, Eigen::Matrix<double, 3, 2>* d_control) {
  const double a = u.w * dt, s = u.v * dt;
  const ArcCoefficients c = Arc(a);
  if (d_control != nullptr) {
    *d_control << dt * c.f1, s * c.df1 * dt,  //
        dt * c.f2, s * c.df2 * dt,            //
        0, dt;
  }
  return Eigen::Vector3d(s * c.f1, s * c.f2, a);
}

SE2d Move(const SE2d& pose, const Control& u, double dt, Eigen::Matrix3d* d_pose,
          Eigen::Matrix<double, 3, 2>* d_control) {
  Eigen::Matrix<double, 3, 2> g;
  const Eigen::Vector3d d = RelativeMotion(u, dt, d_control != nullptr ? &g : nullptr);
  const double ct = std::cos(pose.theta()), st = std::sin(pose.theta());
  const double dx = ct * d.x() - st * d.y(), dy = st * d.x() + ct * d.y();
  if (d_pose != nullptr) {
    d_pose->setIdentity();
    (*d_pose)(0, 2) = -dy;
    (*d_pose)(1, 2) = dx;
  }
  if (d_control != nullptr) {
    Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
    r.topLeftCorner<2, 2>() << ct, -st, st, ct;
    *d_control = r * g;
  }
  // theta + a unwrapped, then wrapped once by the constructor.
  return SE2d(pose.x() + dx, pose.y() + dy, pose.theta() + d.z());
}

MotionIntegrator::MotionIntegrator(const OdometryNoise& noise) : noise_(noise) {
  if (!IsControlCovariance(noise_.control)) {
    throw InvalidArgument("the control covariance must be symmetric, finite and positive semi-definite");
  }
  if (!PositiveFinite(noise_.floor_sigma)) {
    throw InvalidArgument("floor_sigma must be positive and finite, got " + std::to_string(noise_.floor_sigma));
  }
}

Control ControlBetween(const SE2d& from, const SE2d& to, double dt) {
  if (!(dt > 0 && std::isfinite(dt))) throw InvalidArgument("ControlBetween: dt must be positive and finite");
  const SE2d d = from.Inverse() * to;
  const double a = d.theta();
  const double chord = std::hypot(d.x(), d.y());
  // An arc turning by a has chord 2 r sin(a/2) and length r a: length = chord (a/2) / sin(a/2).
  const double half = 0.5 * a;
  const double ratio = std::abs(half) < 1e-6 ? 1.0 + half * half / 6.0 : half / std::sin(half);
  const double length = chord * ratio;
  // Forwards where the chord points ahead of the robot, backwards where it points behind it.
  const double sign = std::cos(std::atan2(d.y(), d.x()) - half) < 0 ? -1.0 : 1.0;
  return Control{sign * length / dt, a / dt};
}

void MotionIntegrator::Add(const Control& u, double dt) {
  if (!PositiveFinite(dt) || !std::isfinite(u.v) || !std::isfinite(u.w)) {
    throw InvalidArgument("a control needs finite v, w and a positive, finite dt");
  }
  Eigen::Matrix3d f;
  Eigen::Matrix<double, 3, 2> g;
  relative_ = Move(relative_, u, dt, &f, &g);
  covariance_ = f * covariance_ * f.transpose() + g * noise_.control * g.transpose();
  covariance_ = 0.5 * (covariance_ + covariance_.transpose()).eval();
  ++steps_;
}

void MotionIntegrator::AddMotion(const SE2d& delta, double dt) {
  const Control u = ControlBetween(SE2d(), delta, dt);  // throws for a bad dt
  if (!std::isfinite(u.v) || !std::isfinite(u.w)) throw InvalidArgument("a motion needs a finite pose change");
  Eigen::Matrix3d f;
  Eigen::Matrix<double, 3, 2> g;
  Move(relative_, u, dt, &f, &g);
  relative_ = relative_ * delta;
  covariance_ = f * covariance_ * f.transpose() + g * noise_.control * g.transpose();
  covariance_ = 0.5 * (covariance_ + covariance_.transpose()).eval();
  ++steps_;
}

Eigen::Matrix3d MotionIntegrator::Information() const {
  // BetweenSE2's error holds the translation in the measured relative pose's frame,
  // e = (R_z^T (t - t_z), theta - theta_z): its covariance is J C J^T with J = diag(R_z^T, 1),
  // and J is orthogonal, so the information is J C^-1 J^T.
  const Eigen::Matrix3d c = covariance_ + noise_.floor_sigma * noise_.floor_sigma * Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d info = c.llt().solve(Eigen::Matrix3d::Identity());
  const double co = std::cos(relative_.theta()), si = std::sin(relative_.theta());
  Eigen::Matrix3d j = Eigen::Matrix3d::Identity();
  j.topLeftCorner<2, 2>() << co, si, -si, co;
  const Eigen::Matrix3d rotated = j * info * j.transpose();
  return 0.5 * (rotated + rotated.transpose());
}

void MotionIntegrator::Reset() {
  relative_ = SE2d();
  covariance_.setZero();
  steps_ = 0;
}

}  // namespace odometry
}  // namespace tether
