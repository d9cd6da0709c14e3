#pragma once
// Internal: when the minimizer stops, in one place. Each rule sets the summary's status and
// message; the messages are built only when a rule fires, never in the loop otherwise.
#include <vector>

#include "tether/solvers/solver_options.h"

namespace tether {
namespace internal {

class StoppingRules {
 public:
  explicit StoppingRules(const SolverOptions& options) : o_(options) {}
  /// Before the first iteration: the status is kMaxIterations until a rule fires (converged
  /// at once where the gradient is below gradient_tolerance).
  void AtStart(const std::vector<double>& gradient, SolverSummary* s) const;
  /// Before each iteration: whether another may run (false once a rule has fired, the
  /// iterations are spent, or max_seconds has passed; the last sets kTimeLimit).
  bool MayIterate(double seconds, SolverSummary* s) const;
  /// After an accepted step from old_chi2 to chi2: the function, gradient and parameter
  /// tolerances.
  void AfterAcceptedStep(double old_chi2, double chi2, const std::vector<double>& gradient, double step_norm,
                         double x_norm, SolverSummary* s) const;

 private:
  const SolverOptions& o_;
};

}  // namespace internal
}  // namespace tether
