#include "tether/core/variable.h"

namespace tether {

std::string_view ToString(VarType t) {
  switch (t) {
    case VarType::kSE2:
      return "SE2";
    case VarType::kSE3:
      return "SE3";
    case VarType::kPoint2:
      return "Point2";
    case VarType::kPoint3:
      return "Point3";
  }
  return "unknown";
}

bool FromString(std::string_view name, VarType* t) {
  for (int i = 0; i < kNumVarTypes; ++i) {
    const VarType v = static_cast<VarType>(i);
    if (ToString(v) == name) {
      *t = v;
      return true;
    }
  }
  return false;
}

void LocalParams(VarType type, const double* x, const double* y, double* delta) {
  switch (type) {
    case VarType::kSE2: {
      const Eigen::Vector3d d = SE2d::FromParams(x).Local(SE2d::FromParams(y));
      for (int i = 0; i < 3; ++i) delta[i] = d[i];
      break;
    }
    case VarType::kSE3: {
      const Eigen::Matrix<double, 6, 1> d = SE3d::FromParams(x).Local(SE3d::FromParams(y));
      for (int i = 0; i < 6; ++i) delta[i] = d[i];
      break;
    }
    case VarType::kPoint2:
    case VarType::kPoint3:
      for (int i = 0; i < AmbientDim(type); ++i) delta[i] = y[i] - x[i];
      break;
  }
}

}  // namespace tether
