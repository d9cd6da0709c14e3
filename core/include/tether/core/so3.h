#pragma once
// SO(3): rotations in space, stored as a unit quaternion (Eigen order x, y, z, w).
//
// Tangent vectors are rotation vectors (axis * angle) in the body frame. Exp and Log are
// written so that ceres::Jet derivatives stay finite at the identity (first-order branch)
// and Log stays accurate near a rotation by pi (atan2 of the vector part's norm).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace tether {

/// Skew-symmetric matrix [v]x with [v]x * u == v.cross(u).
template <typename T>
Eigen::Matrix<T, 3, 3> Skew(const Eigen::Matrix<T, 3, 1>& v) {
  Eigen::Matrix<T, 3, 3> m;
  m << T(0), -v.z(), v.y(), v.z(), T(0), -v.x(), -v.y(), v.x(), T(0);
  return m;
}

template <typename T = double>
class SO3 {
 public:
  using Scalar = T;
  static constexpr int kDim = 3;
  using Vector3 = Eigen::Matrix<T, 3, 1>;
  using Matrix3 = Eigen::Matrix<T, 3, 3>;
  using Quaternion = Eigen::Quaternion<T>;

  SO3() : q_(T(1), T(0), T(0), T(0)) {}
  /// Normalises q. Throws nothing: a zero quaternion is a caller error checked by readers.
  explicit SO3(const Quaternion& q) : q_(q) { q_.normalize(); }

  static SO3 Exp(const Vector3& w) {
    using std::cos;
    using std::sin;
    using std::sqrt;
    const T th2 = w.squaredNorm();
    Quaternion q;
    if (th2 < T(1e-16)) {
      // First-order branch: exact value and exact derivative at w == 0 (also for Jets).
      q = Quaternion(T(1), w.x() / T(2), w.y() / T(2), w.z() / T(2));
    } else {
      const T th = sqrt(th2);
      const T k = sin(th / T(2)) / th;
      q = Quaternion(cos(th / T(2)), k * w.x(), k * w.y(), k * w.z());
    }
    return SO3(q);
  }

  Vector3 Log() const {
    using std::atan2;
    using std::sqrt;
    Quaternion q = q_;
    if (q.w() < T(0)) q.coeffs() = -q.coeffs();
    const T n2 = q.vec().squaredNorm();
    if (n2 < T(1e-16)) {
      return T(2) * q.vec() / q.w();
    }
    const T n = sqrt(n2);
    const T th = T(2) * atan2(n, q.w());
    return (th / n) * q.vec();
  }

  const Quaternion& quaternion() const { return q_; }
  Matrix3 matrix() const { return q_.toRotationMatrix(); }
  SO3 Inverse() const { return SO3(q_.conjugate()); }
  SO3 operator*(const SO3& o) const { return SO3(q_ * o.q_); }
  Vector3 operator*(const Vector3& v) const { return q_ * v; }
  Matrix3 Adjoint() const { return matrix(); }

 private:
  Quaternion q_;
};

using SO3d = SO3<double>;

}  // namespace tether
