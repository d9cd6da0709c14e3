#pragma once
// RangeBearing2 (g2o-style tag EDGE_RANGE_BEARING_SE2_XY, SE2 pose to VERTEX_XY): the range and
// bearing of a 2D landmark seen from a pose, as a laser or radar measures a tree or a beacon.
//
// With d = R^T (l - t) the landmark in the pose's frame (R, t the pose's rotation and position):
//   e = [ |d| - range , WrapAngle(atan2(d_y, d_x) - bearing) ]
// The bearing is measured counter-clockwise from the pose's x axis, in radians; the error's
// second entry is wrapped to (-pi, pi], so a bearing of pi and one of -pi are the same.
//
// Jacobians (SE2 tangent as every SE2 factor uses it: t + R dt, theta + dtheta; r = |d|):
//   d e / d pose     = [ -d_x/r    -d_y/r      0 ]      d e / d landmark = [  d^T R^T / r       ]
//                      [  d_y/r^2  -d_x/r^2   -1 ]                         [ (-d_y, d_x) R^T / r^2 ]
//
// Range 0 (the landmark on the pose's position): the bearing, and the Jacobian of both rows,
// are undefined there (1/r and 1/r^2 grow without bound). Evaluate returns false (never NaN)
// where r <= kMinRange; the solvers then count the point as not evaluable: a trial step that
// lands there is rejected, and a start there is refused naming this factor ("fails to
// evaluate"). A measured range of 0 is accepted (the landmark is then pulled onto the pose, so
// its estimate must start elsewhere); a negative or non-finite range or bearing is refused.
#include "tether/core/factor.h"

namespace tether {

class RangeBearing2 : public TypedFactor<RangeBearing2, 2, SE2d, Eigen::Vector2d> {
 public:
  static constexpr const char* kTypeName = "RangeBearing2";
  /// Below this distance between landmark and pose the factor is not evaluated (see above).
  static constexpr double kMinRange = 1e-9;

  /// Throws InvalidArgument where `range` is negative or not finite, or `bearing` not finite.
  RangeBearing2(Key pose, Key point, double range, double bearing, SqrtInformation noise);
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  /// {range, bearing}, the bearing as given (not wrapped).
  std::vector<double> Measurement() const override { return {range_, bearing_}; }
  /// The landmark from the pose (pose known): t + R * range * (cos bearing, sin bearing). A
  /// pose cannot be placed from one landmark, so the other direction returns false.
  bool Predict(std::size_t known, const double* known_params, std::size_t unknown, double* out) const override;

  double range() const { return range_; }
  double bearing() const { return bearing_; }

 private:
  double range_;
  double bearing_;
};

}  // namespace tether
