#pragma once
// SE(2): planar rigid motions, stored as (x, y, theta) with theta wrapped to (-pi, pi].
//
// Tangent vectors are ordered (rho_x, rho_y, theta) and expressed in the body frame.
// Exp/Log are the exact group exponential and logarithm. The retraction used by the
// solvers (box-plus) is the cheaper product form: t + R * dt, theta + dtheta; Local is its
// exact inverse. Both agree with Exp to first order.
#include <Eigen/Core>
#include <cmath>
#include <ostream>

#include "tether/core/so2.h"

namespace tether {

template <typename T = double>
class SE2 {
 public:
  using Scalar = T;
  static constexpr int kDim = 3;
  static constexpr int kAmbientDim = 3;
  using Vector2 = Eigen::Matrix<T, 2, 1>;
  using Vector3 = Eigen::Matrix<T, 3, 1>;
  using Matrix3 = Eigen::Matrix<T, 3, 3>;

  SE2() : t_(Vector2::Zero()), theta_(T(0)) {}
  SE2(const T& x, const T& y, const T& theta) : t_(x, y), theta_(WrapAngle(theta)) {}
  SE2(const SO2<T>& r, const Vector2& t) : t_(t), theta_(r.angle()) {}

  /// Builds from the parameter layout [x, y, theta].
  static SE2 FromParams(const T* p) { return SE2(p[0], p[1], p[2]); }
  void ToParams(T* p) const {
    p[0] = t_.x();
    p[1] = t_.y();
    p[2] = theta_;
  }

  const Vector2& translation() const { return t_; }
  T x() const { return t_.x(); }
  T y() const { return t_.y(); }
  T theta() const { return theta_; }
  SO2<T> rotation() const { return SO2<T>(theta_); }

  SE2 operator*(const SE2& o) const { return SE2(rotation(), t_ + rotation() * o.t_).WithAngle(theta_ + o.theta_); }
  Vector2 operator*(const Vector2& p) const { return t_ + rotation() * p; }
  SE2 Inverse() const {
    const SO2<T> rinv(-theta_);
    return SE2(rinv, -(rinv * t_));
  }

  /// Exact group exponential of (rho_x, rho_y, theta).
  static SE2 Exp(const Vector3& v) {
    const T th = v[2];
    T a, b;  // V = [a -b; b a]
    VCoefficients(th, &a, &b);
    return SE2(a * v[0] - b * v[1], b * v[0] + a * v[1], th);
  }

  /// Exact group logarithm; inverse of Exp for |theta| < pi.
  Vector3 Log() const {
    const T th = theta_;
    T a, b;
    VCoefficients(th, &a, &b);
    const T det = a * a + b * b;  // V^{-1} = [a b; -b a] / det
    return Vector3((a * t_.x() + b * t_.y()) / det, (-b * t_.x() + a * t_.y()) / det, th);
  }

  /// Adjoint for tangent order (rho, theta): [[R, (y, -x)^T], [0, 1]].
  Matrix3 Adjoint() const {
    Matrix3 m = Matrix3::Zero();
    m.template topLeftCorner<2, 2>() = rotation().matrix();
    m(0, 2) = t_.y();
    m(1, 2) = -t_.x();
    m(2, 2) = T(1);
    return m;
  }

  /// Box-plus: translation moved in the body frame, angle added.
  SE2 Retract(const Vector3& d) const {
    return SE2(rotation(), t_ + rotation() * Vector2(d[0], d[1])).WithAngle(theta_ + d[2]);
  }
  /// Box-minus: the delta d with this->Retract(d) == other (angle wrapped).
  Vector3 Local(const SE2& other) const {
    const Vector2 dt = SO2<T>(-theta_) * (other.t_ - t_);
    return Vector3(dt.x(), dt.y(), WrapAngle(other.theta_ - theta_));
  }

  Matrix3 matrix() const {
    Matrix3 m = Matrix3::Identity();
    m.template topLeftCorner<2, 2>() = rotation().matrix();
    m.template topRightCorner<2, 1>() = t_;
    return m;
  }

 private:
  // Coefficients of V(theta) = [a -b; b a], the left Jacobian of SO(2) acting on translations.
  static void VCoefficients(const T& th, T* a, T* b) {
    using std::abs;
    using std::cos;
    using std::sin;
    if (abs(th) < T(1e-9)) {
      *a = T(1) - th * th / T(6);
      *b = th / T(2);
    } else {
      *a = sin(th) / th;
      *b = (T(1) - cos(th)) / th;
    }
  }
  SE2 WithAngle(const T& a) const {
    SE2 r = *this;
    r.theta_ = WrapAngle(a);
    return r;
  }
  Vector2 t_;
  T theta_;
};

using SE2d = SE2<double>;

/// "SE2(x, y, theta)".
template <typename T>
std::ostream& operator<<(std::ostream& os, const SE2<T>& p) {
  return os << "SE2(" << p.x() << ", " << p.y() << ", " << p.theta() << ")";
}

}  // namespace tether
