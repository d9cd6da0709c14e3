#pragma once
// SO(2): planar rotations, stored as an angle wrapped to (-pi, pi].
#include <Eigen/Core>
#include <cmath>

namespace tether {

/// Wraps an angle to (-pi, pi]. Works for double and ceres::Jet.
template <typename T>
T WrapAngle(const T& a) {
  using std::atan2;
  using std::cos;
  using std::floor;
  using std::sin;
  const double kPi = 3.14159265358979323846;
  // Fast path for the common case; exact for values already in range.
  // One reduction brings any angle below about 1e16 into range. Beyond that the product
  // 2 pi floor(...) has lost the digits the difference needs, so one pass only shrinks the
  // magnitude (by about 16 orders); repeating it ends in range within 20 passes for any finite
  // angle (1.7e308 included), so the result is always in (-pi, pi] and wrapping it again gives
  // it back. Infinities and NaN become NaN on the first pass and leave the loop.
  T r = a;
  for (int pass = 0; pass < 32 && (r > T(kPi) || r <= T(-kPi)); ++pass) {
    r = r - T(2.0 * kPi) * floor((r + T(kPi)) / T(2.0 * kPi));
    if (r <= T(-kPi)) r = r + T(2.0 * kPi);
    if (r > T(kPi)) r = r - T(2.0 * kPi);
  }
  return r;
}

template <typename T = double>
class SO2 {
 public:
  using Scalar = T;
  static constexpr int kDim = 1;
  using Matrix2 = Eigen::Matrix<T, 2, 2>;
  using Vector2 = Eigen::Matrix<T, 2, 1>;

  SO2() : theta_(T(0)) {}
  explicit SO2(const T& theta) : theta_(WrapAngle(theta)) {}

  static SO2 Exp(const T& theta) { return SO2(theta); }
  T Log() const { return theta_; }
  const T& angle() const { return theta_; }

  SO2 Inverse() const { return SO2(-theta_); }
  SO2 operator*(const SO2& o) const { return SO2(theta_ + o.theta_); }
  Vector2 operator*(const Vector2& v) const {
    using std::cos;
    using std::sin;
    const T c = cos(theta_), s = sin(theta_);
    return Vector2(c * v.x() - s * v.y(), s * v.x() + c * v.y());
  }
  Matrix2 matrix() const {
    using std::cos;
    using std::sin;
    const T c = cos(theta_), s = sin(theta_);
    Matrix2 m;
    m << c, -s, s, c;
    return m;
  }
  /// The adjoint of SO(2) is the identity (the group is abelian).
  T Adjoint() const { return T(1); }

 private:
  T theta_;
};

using SO2d = SO2<double>;

}  // namespace tether
