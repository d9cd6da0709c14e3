#include "tether/factors/range_bearing.h"

#include <cmath>
#include <string>

#include "tether/core/registry.h"

namespace tether {

RangeBearing2::RangeBearing2(Key pose, Key point, double range, double bearing, SqrtInformation noise)
    : TypedFactor({pose, point}, std::move(noise)), range_(range), bearing_(bearing) {
  if (!std::isfinite(range) || range < 0) {
    throw InvalidArgument("the range is " + FormatDouble(range) + "; a range is a distance, finite and not negative");
  }
  if (!std::isfinite(bearing)) {
    throw InvalidArgument("the bearing is " + FormatDouble(bearing) + "; a bearing is a finite angle in radians");
  }
}

bool RangeBearing2::Evaluate(const double* const* params, double* error, double* const* jacobians) const {
  const double* x = params[0];
  const double* l = params[1];
  const double c = std::cos(x[2]), s = std::sin(x[2]);
  const double wx = l[0] - x[0], wy = l[1] - x[1];
  const double dx = c * wx + s * wy, dy = -s * wx + c * wy;  // d = R^T (l - t)
  const double r = std::hypot(dx, dy);
  if (!(r > kMinRange)) return false;  // bearing undefined (see the header)
  error[0] = r - range_;
  error[1] = WrapAngle(std::atan2(dy, dx) - bearing_);
  if (jacobians == nullptr) return true;
  const double r2 = r * r;
  if (double* J = jacobians[0]) {
    J[0] = -dx / r, J[1] = -dy / r, J[2] = 0;
    J[3] = dy / r2, J[4] = -dx / r2, J[5] = -1;
  }
  if (double* J = jacobians[1]) {
    // d d / d l = R^T, so the rows are (d / r)^T R^T and (-d_y, d_x) R^T / r^2.
    J[0] = (dx * c - dy * s) / r, J[1] = (dx * s + dy * c) / r;
    J[2] = (-dy * c - dx * s) / r2, J[3] = (-dy * s + dx * c) / r2;
  }
  return true;
}

bool RangeBearing2::Predict(std::size_t known, const double* kp, std::size_t unknown, double* out) const {
  if (known != 0 || unknown != 1) return false;
  const double a = kp[2] + bearing_;
  out[0] = kp[0] + range_ * std::cos(a);
  out[1] = kp[1] + range_ * std::sin(a);
  return true;
}

}  // namespace tether
