#pragma once
// BetweenSE2 (g2o EDGE_SE2): relative pose measurement Z between two SE2 poses.
// Error, as g2o defines it: e = toVector(Z^-1 * (Xi^-1 * Xj)) = (x, y, wrapped theta).
#include "tether/core/factor.h"

namespace tether {

class BetweenSE2 : public Factor {
 public:
  BetweenSE2(Key i, Key j, const SE2d& z, SqrtInformation noise) : Factor({i, j}, noise), z_(z) {}
  std::string type_name() const override { return "BetweenSE2"; }
  int residual_dim() const override { return 3; }
  std::vector<VarType> variable_types() const override { return {VarType::kSE2, VarType::kSE2}; }
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  std::unique_ptr<Factor> Clone() const override { return std::make_unique<BetweenSE2>(*this); }
  std::vector<double> Measurement() const override { return {z_.x(), z_.y(), z_.theta()}; }
  bool Predict(std::size_t known, const double* known_params, std::size_t unknown, double* out) const override;
  const SE2d& measured() const { return z_; }

 private:
  SE2d z_;
};

}  // namespace tether
