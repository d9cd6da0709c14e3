#pragma once
// BetweenSE2 (g2o EDGE_SE2): relative pose measurement Z between two SE2 poses.
// Error, as g2o defines it: e = toVector(Z^-1 * (Xi^-1 * Xj)) = (x, y, wrapped theta).
#include <cmath>

#include "tether/core/factor.h"

namespace tether {

class BetweenSE2 : public TypedFactor<BetweenSE2, 3, SE2d, SE2d> {
 public:
  static constexpr const char* kTypeName = "BetweenSE2";
  BetweenSE2(Key i, Key j, const SE2d& z, SqrtInformation noise)
      : TypedFactor({i, j}, std::move(noise)), z_(z), cz_(std::cos(z.theta())), sz_(std::sin(z.theta())) {}
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  std::vector<double> Measurement() const override { return {z_.x(), z_.y(), z_.theta()}; }
  bool Predict(std::size_t known, const double* known_params, std::size_t unknown, double* out) const override;
  const SE2d& measured() const { return z_; }

 private:
  SE2d z_;
  double cz_, sz_;  // cos and sin of z's angle, for every evaluation
};

}  // namespace tether
