#pragma once
// SE(3): rigid motions in space, stored as a unit quaternion and a translation.
//
// Parameter layout (as in g2o's VERTEX_SE3:QUAT): [tx, ty, tz, qx, qy, qz, qw].
// Tangent vectors are ordered (rho, omega): translation part first, then rotation vector.
// Exp/Log are the exact group maps. The solvers' retraction (box-plus) is the product form
// t + R * dt, R * Exp(domega); Local is its exact inverse.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <ostream>

#include "tether/core/so3.h"

namespace tether {

template <typename T = double>
class SE3 {
 public:
  using Scalar = T;
  static constexpr int kDim = 6;
  static constexpr int kAmbientDim = 7;
  using Vector3 = Eigen::Matrix<T, 3, 1>;
  using Vector6 = Eigen::Matrix<T, 6, 1>;
  using Matrix3 = Eigen::Matrix<T, 3, 3>;
  using Matrix4 = Eigen::Matrix<T, 4, 4>;
  using Matrix6 = Eigen::Matrix<T, 6, 6>;
  using Quaternion = Eigen::Quaternion<T>;

  SE3() : r_(), t_(Vector3::Zero()) {}
  SE3(const SO3<T>& r, const Vector3& t) : r_(r), t_(t) {}
  SE3(const Quaternion& q, const Vector3& t) : r_(q), t_(t) {}

  static SE3 FromParams(const T* p) { return SE3(Quaternion(p[6], p[3], p[4], p[5]), Vector3(p[0], p[1], p[2])); }
  void ToParams(T* p) const {
    p[0] = t_.x();
    p[1] = t_.y();
    p[2] = t_.z();
    const Quaternion& q = r_.quaternion();
    p[3] = q.x();
    p[4] = q.y();
    p[5] = q.z();
    p[6] = q.w();
  }

  const SO3<T>& rotation() const { return r_; }
  const Vector3& translation() const { return t_; }
  const Quaternion& quaternion() const { return r_.quaternion(); }

  SE3 operator*(const SE3& o) const { return SE3(r_ * o.r_, t_ + r_ * o.t_); }
  Vector3 operator*(const Vector3& p) const { return t_ + r_ * p; }
  SE3 Inverse() const {
    const SO3<T> ri = r_.Inverse();
    return SE3(ri, -(ri * t_));
  }

  static SE3 Exp(const Vector6& v) {
    const Vector3 rho = v.template head<3>();
    const Vector3 w = v.template tail<3>();
    return SE3(SO3<T>::Exp(w), LeftJacobian(w) * rho);
  }
  Vector6 Log() const {
    const Vector3 w = r_.Log();
    Vector6 out;
    out.template head<3>() = LeftJacobian(w).inverse() * t_;
    out.template tail<3>() = w;
    return out;
  }

  /// Adjoint for tangent order (rho, omega): [[R, [t]x R], [0, R]].
  Matrix6 Adjoint() const {
    const Matrix3 R = r_.matrix();
    Matrix6 m = Matrix6::Zero();
    m.template topLeftCorner<3, 3>() = R;
    m.template topRightCorner<3, 3>() = Skew(t_) * R;
    m.template bottomRightCorner<3, 3>() = R;
    return m;
  }

  SE3 Retract(const Vector6& d) const {
    return SE3(r_ * SO3<T>::Exp(d.template tail<3>()), t_ + r_ * Vector3(d.template head<3>()));
  }
  Vector6 Local(const SE3& other) const {
    Vector6 out;
    const SO3<T> ri = r_.Inverse();
    out.template head<3>() = ri * (other.t_ - t_);
    out.template tail<3>() = (ri * other.r_).Log();
    return out;
  }

  Matrix4 matrix() const {
    Matrix4 m = Matrix4::Identity();
    m.template topLeftCorner<3, 3>() = r_.matrix();
    m.template topRightCorner<3, 1>() = t_;
    return m;
  }

  /// Left Jacobian of SO(3) (the V matrix of the SE(3) exponential).
  static Matrix3 LeftJacobian(const Vector3& w) {
    using std::cos;
    using std::sin;
    using std::sqrt;
    const T th2 = w.squaredNorm();
    const Matrix3 K = Skew(w);
    if (th2 < T(1e-12)) return Matrix3::Identity() + K / T(2) + K * K / T(6);
    const T th = sqrt(th2);
    return Matrix3::Identity() + ((T(1) - cos(th)) / th2) * K + ((th - sin(th)) / (th2 * th)) * K * K;
  }

 private:
  SO3<T> r_;
  Vector3 t_;
};

using SE3d = SE3<double>;

/// "SE3(t: x, y, z; q: qx, qy, qz, qw)".
template <typename T>
std::ostream& operator<<(std::ostream& os, const SE3<T>& p) {
  const auto& t = p.translation();
  const auto& q = p.quaternion();
  return os << "SE3(t: " << t.x() << ", " << t.y() << ", " << t.z() << "; q: " << q.x() << ", " << q.y() << ", "
            << q.z() << ", " << q.w() << ")";
}

}  // namespace tether
