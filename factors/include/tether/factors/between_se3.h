#pragma once
// BetweenSE3 (g2o EDGE_SE3:QUAT): relative pose measurement Z between two SE3 poses.
// Error, as g2o defines it: E = Z^-1 * (Xi^-1 * Xj); e = (t_E, vector part of q_E) with q_E
// taken with a non-negative scalar part. The information matrix acts on that 6-vector.
#include "tether/core/factor.h"

namespace tether {

class BetweenSE3 : public Factor {
 public:
  BetweenSE3(Key i, Key j, const SE3d& z, SqrtInformation noise) : Factor({i, j}, noise), z_(z) {}
  std::string type_name() const override { return "BetweenSE3"; }
  int residual_dim() const override { return 6; }
  std::vector<VarType> variable_types() const override { return {VarType::kSE3, VarType::kSE3}; }
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  std::unique_ptr<Factor> Clone() const override { return std::make_unique<BetweenSE3>(*this); }
  std::vector<double> Measurement() const override;
  bool Predict(std::size_t known, const double* known_params, std::size_t unknown, double* out) const override;
  const SE3d& measured() const { return z_; }

 private:
  SE3d z_;
};

}  // namespace tether
