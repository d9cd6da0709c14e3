#pragma once
// Priors on a single pose.
// PriorSE2 (g2o EDGE_PRIOR_SE2): e = toVector(Z^-1 * X), as BetweenSE2 with Xi = identity.
// PriorSE3:                      e = (t_E, vec(q_E)) of E = Z^-1 * X, as BetweenSE3.
#include <cmath>

#include "tether/core/factor.h"

namespace tether {

class PriorSE2 : public TypedFactor<PriorSE2, 3, SE2d> {
 public:
  static constexpr const char* kTypeName = "PriorSE2";
  PriorSE2(Key k, const SE2d& z, SqrtInformation noise)
      : TypedFactor({k}, std::move(noise)), z_(z), cz_(std::cos(z.theta())), sz_(std::sin(z.theta())) {}
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  std::vector<double> Measurement() const override { return {z_.x(), z_.y(), z_.theta()}; }

 private:
  SE2d z_;
  double cz_, sz_;  // cos and sin of z's angle, for every evaluation
};

class PriorSE3 : public TypedFactor<PriorSE3, 6, SE3d> {
 public:
  static constexpr const char* kTypeName = "PriorSE3";
  PriorSE3(Key k, const SE3d& z, SqrtInformation noise) : TypedFactor({k}, std::move(noise)), z_(z) {}
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  std::vector<double> Measurement() const override;

 private:
  SE3d z_;
};

}  // namespace tether
