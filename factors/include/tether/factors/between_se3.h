#pragma once
// BetweenSE3 (g2o EDGE_SE3:QUAT): relative pose measurement Z between two SE3 poses.
// Error, as g2o defines it: E = Z^-1 * (Xi^-1 * Xj); e = (t_E, vector part of q_E) with q_E
// taken with a non-negative scalar part. The information matrix acts on that 6-vector.
#include "tether/core/factor.h"

namespace tether {

class BetweenSE3 : public TypedFactor<BetweenSE3, 6, SE3d, SE3d> {
 public:
  static constexpr const char* kTypeName = "BetweenSE3";
  BetweenSE3(Key i, Key j, const SE3d& z, SqrtInformation noise) : TypedFactor({i, j}, std::move(noise)), z_(z) {}
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  std::vector<double> Measurement() const override;
  bool Predict(std::size_t known, const double* known_params, std::size_t unknown, double* out) const override;
  const SE3d& measured() const { return z_; }

 private:
  SE3d z_;
};

}  // namespace tether
