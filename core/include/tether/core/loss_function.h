#pragma once
// LossFunction: a robust loss rho(s) on a factor's squared whitened error s = |R e|^2.
//
// A factor carries an optional loss beside its noise model (Factor::set_loss); its cost is
// then rho(s) instead of s. The built-in losses are in robust_kernels.h; how the solvers
// apply them (reweighted least squares, RobustWeight) is in docs/solvers.md, "Robust losses".
#include <string>

namespace tether {

class LossFunction {
 public:
  virtual ~LossFunction() = default;
  /// A short name for reports, e.g. "huber:1".
  virtual std::string name() const = 0;
  /// rho[0] = rho(s), rho[1] = rho'(s), rho[2] = rho''(s) for s >= 0.
  virtual void Evaluate(double s, double rho[3]) const = 0;
};

}  // namespace tether
