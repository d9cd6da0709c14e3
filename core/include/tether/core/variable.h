#pragma once
// The variable types a Values can hold, their parameter layouts and manifold operations.
//
// | type   | ambient params              | tangent | retraction (box-plus)          |
// |--------|-----------------------------|---------|--------------------------------|
// | SE2    | x y theta                   | 3       | t + R dt, theta + dtheta       |
// | SE3    | tx ty tz qx qy qz qw        | 6       | t + R dt, R Exp(dw)            |
// | Point2 | x y                         | 2       | p + d                          |
// | Point3 | x y z                       | 3       | p + d                          |
#include <array>
#include <string_view>

#include "tether/core/se2.h"
#include "tether/core/se3.h"

namespace tether {

enum class VarType : unsigned char { kSE2 = 0, kSE3 = 1, kPoint2 = 2, kPoint3 = 3 };
constexpr int kNumVarTypes = 4;

constexpr int TangentDim(VarType t) {
  constexpr int d[] = {3, 6, 2, 3};
  return d[static_cast<int>(t)];
}
constexpr int AmbientDim(VarType t) {
  constexpr int d[] = {3, 7, 2, 3};
  return d[static_cast<int>(t)];
}
/// The identity (origin) of a type in its ambient parameters.
inline void IdentityParams(VarType t, double* p) {
  for (int i = 0; i < AmbientDim(t); ++i) p[i] = 0.0;
  if (t == VarType::kSE3) p[6] = 1.0;  // qw
}
/// "SE2", "SE3", "Point2", "Point3".
std::string_view ToString(VarType t);
/// Inverse of ToString; returns false for an unknown name.
bool FromString(std::string_view name, VarType* t);
inline bool IsPose(VarType t) { return t == VarType::kSE2 || t == VarType::kSE3; }

/// Box-plus on raw parameters, templated so that automatic differentiation can use it:
/// out = x (+) delta. x and out may alias.
template <typename T>
void RetractParams(VarType type, const T* x, const T* delta, T* out) {
  switch (type) {
    case VarType::kSE2: {
      SE2<T>::FromParams(x).Retract(Eigen::Matrix<T, 3, 1>(delta[0], delta[1], delta[2])).ToParams(out);
      break;
    }
    case VarType::kSE3: {
      Eigen::Matrix<T, 6, 1> d;
      for (int i = 0; i < 6; ++i) d[i] = delta[i];
      SE3<T>::FromParams(x).Retract(d).ToParams(out);
      break;
    }
    case VarType::kPoint2:
      for (int i = 0; i < 2; ++i) out[i] = x[i] + delta[i];
      break;
    case VarType::kPoint3:
      for (int i = 0; i < 3; ++i) out[i] = x[i] + delta[i];
      break;
  }
}

/// Box-minus on raw parameters: delta with x (+) delta == y.
void LocalParams(VarType type, const double* x, const double* y, double* delta);

}  // namespace tether
