#pragma once
// Priors on a single pose.
// PriorSE2 (g2o EDGE_PRIOR_SE2): e = toVector(Z^-1 * X), as BetweenSE2 with Xi = identity.
// PriorSE3:                      e = (t_E, vec(q_E)) of E = Z^-1 * X, as BetweenSE3.
#include "tether/core/factor.h"

namespace tether {

class PriorSE2 : public Factor {
 public:
  PriorSE2(Key k, const SE2d& z, SqrtInformation noise) : Factor({k}, noise), z_(z) {}
  std::string type_name() const override { return "PriorSE2"; }
  int residual_dim() const override { return 3; }
  std::vector<VarType> variable_types() const override { return {VarType::kSE2}; }
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  std::unique_ptr<Factor> Clone() const override { return std::make_unique<PriorSE2>(*this); }
  std::vector<double> Measurement() const override { return {z_.x(), z_.y(), z_.theta()}; }

 private:
  SE2d z_;
};

class PriorSE3 : public Factor {
 public:
  PriorSE3(Key k, const SE3d& z, SqrtInformation noise) : Factor({k}, noise), z_(z) {}
  std::string type_name() const override { return "PriorSE3"; }
  int residual_dim() const override { return 6; }
  std::vector<VarType> variable_types() const override { return {VarType::kSE3}; }
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  std::unique_ptr<Factor> Clone() const override { return std::make_unique<PriorSE3>(*this); }
  std::vector<double> Measurement() const override;

 private:
  SE3d z_;
};

}  // namespace tether
