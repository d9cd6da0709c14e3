#pragma once
// The built-in robust losses (LossFunction, loss_function.h): rho of a factor's squared
// whitened error s = |R e|^2. Every one has rho(0) = 0 and rho'(0) = 1, so that a factor
// whose error is small costs what it costs without a loss, and each grows slower than s
// beyond its scale (docs/solvers.md, "Robust losses"):
//
//   huber:d     rho = s                          for s <= d^2, 2 d sqrt(s) - d^2 beyond
//   cauchy:c    rho = c^2 log(1 + s / c^2)
//   tukey:c     rho = c^2 / 3 (1 - (1 - s / c^2)^3) for s <= c^2, c^2 / 3 beyond
//   gm:c        rho = c^2 s / (c^2 + s)                        (Geman-McClure)
//   dcs:phi     rho = s for s <= phi, phi (3 s - phi) / (phi + s) beyond
//               (dynamic covariance scaling: the factor's information scaled by
//               min(1, 2 phi / (phi + s))^2, which is rho'(s))
//
// The scale (d, c, phi) is in whitened units: huber:1 treats an error beyond one standard
// deviation linearly. They are registered by name in the loss registry (loss_registry.h,
// RegisterBuiltinLosses below) exactly as a plugin's losses are; MakeLoss("NAME:SCALE")
// looks them up there.
#include <memory>
#include <string>

#include "tether/core/loss_function.h"
#include "tether/core/loss_registry.h"

namespace tether {

class HuberLoss : public LossFunction {
 public:
  explicit HuberLoss(double delta);
  std::string name() const override;
  void Evaluate(double s, double rho[3]) const override;
  double delta() const { return delta_; }

 private:
  double delta_;
};

class CauchyLoss : public LossFunction {
 public:
  explicit CauchyLoss(double c);
  std::string name() const override;
  void Evaluate(double s, double rho[3]) const override;

 private:
  double c_;
};

class TukeyLoss : public LossFunction {
 public:
  explicit TukeyLoss(double c);
  std::string name() const override;
  void Evaluate(double s, double rho[3]) const override;

 private:
  double c_;
};

class GemanMcClureLoss : public LossFunction {
 public:
  explicit GemanMcClureLoss(double c);
  std::string name() const override;
  void Evaluate(double s, double rho[3]) const override;

 private:
  double c_;
};

class DcsLoss : public LossFunction {
 public:
  explicit DcsLoss(double phi);
  std::string name() const override;
  void Evaluate(double s, double rho[3]) const override;

 private:
  double phi_;
};

/// How the solvers apply a loss (reweighted least squares, docs/solvers.md "Robust losses"):
/// the weight sqrt(rho'(s)) by which a factor's whitened residual and Jacobians are
/// multiplied, for a factor whose squared whitened error is s (1 without a loss, and where s
/// is not finite); the factor's cost, rho(s) or s, into *cost where not null.
double RobustWeight(const LossFunction* loss, double s, double* cost = nullptr);

/// Registers the losses above as huber, cauchy, tukey, gm and dcs (owner "builtin"), through
/// LossRegistry::Register as a plugin's losses are. DefaultLossRegistry() holds them from its
/// first use; MakeLoss (loss_registry.h) makes one from its text form "NAME:SCALE".
void RegisterBuiltinLosses(LossRegistry& registry);

/// The p quantile of the chi2 distribution with k degrees of freedom (0.99: 9.2 for 2, 11.3
/// for 3, 16.8 for 6), by Wilson and Hilferty's cube-root normal approximation (within 1%
/// from k = 1 at p = 0.99; 117.98 for k = 150 at p = 0.025, as exact to 0.01); p in (0, 1) (0.5:
/// the median), k >= 1. The lower tail is poor for few degrees of freedom (k = 3, p = 0.025:
/// 0.181 against 0.216; 0 for k = 1): frontends/ekf/consistency.h has an exact quantile. The
/// bound on a loop closure's chi2 that GNC and switchable constraints use by default.
double Chi2Quantile(int k, double p);

}  // namespace tether
