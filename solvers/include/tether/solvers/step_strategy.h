#pragma once
// Step strategies: how each iteration's step is proposed from the linearised system, and what
// is learnt from how it went. The iteration loop (stopping rules, accepting or rejecting a
// step, relinearising) is the solver's; a strategy only proposes. Built in: Gauss-Newton
// ("gn"), Levenberg-Marquardt ("lm") and Powell's dog-leg ("dogleg"). More are added by name,
// from a program (RegisterStepStrategy) or from a plugin (AddStepStrategy in its
// registration function: committed with the plugin's other types, all or nothing), and
// selected with SolverOptions::algorithm or `tether optimize --solver NAME`.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "tether/core/linear_solver.h"
#include "tether/solvers/solver_options.h"

namespace tether {

class PluginRegistrar;

/// The system linearised at the current values, as a strategy sees it: gradient g of chi2 / 2
/// and the Gauss-Newton matrix H = J^T J, both in tangent coordinates.
class StepSystem {
 public:
  virtual ~StepSystem() = default;
  /// Counts the linearisations: changes whenever g and H are those of a new point.
  virtual int assemblies() const = 0;
  /// delta solving (H + lambda D) delta = -g, D the clamped diagonal of H (lambda 0: the
  /// Gauss-Newton step). Fills the log row's solver fields.
  virtual LinearSolverStatus Solve(double lambda, std::vector<double>* delta, IterationSummary* it) = 0;
  /// The linear model's decrease of chi2 along d for a step from Solve(lambda) (dDd = d^T D d,
  /// reused: whether the solve reused an earlier factorisation).
  virtual double PredictedDecrease(const std::vector<double>& d, double lambda, double dDd, bool reused) = 0;
  /// d^T D d.
  virtual double ScaledSquaredNorm(const std::vector<double>& d) const = 0;
  /// y = H x (undamped).
  virtual void MultiplyUndamped(const std::vector<double>& x, std::vector<double>* y) = 0;
  virtual const std::vector<double>& gradient() const = 0;
};

/// The values a step is tried at (StepStrategy::Refine may try a shorter one).
class TrialPoint {
 public:
  virtual ~TrialPoint() = default;
  /// Back to the values before the step.
  virtual void Restore() = 0;
  /// x <- x (+) delta for every free variable.
  virtual void Retract(const double* delta) = 0;
  /// chi2 at the current values (+inf where a factor fails).
  virtual double Chi2() const = 0;
};

/// A proposed step: delta is in the caller's vector.
struct Step {
  LinearSolverStatus status = LinearSolverStatus::kOk;
  double predicted_decrease = 0;  ///< of chi2, by the linear model
};

class StepStrategy {
 public:
  virtual ~StepStrategy() = default;
  /// For messages: "Gauss-Newton", ...
  virtual const char* display_name() const = 0;
  /// Writes the strategy's state (LM damping, dog-leg radius) into an iteration's log row.
  virtual void Describe(IterationSummary* it) const = 0;
  /// Whether a step that raises chi2 is taken anyway (Gauss-Newton). The loop then keeps the
  /// best values visited and hands them back at the end; otherwise it takes only steps that
  /// lower chi2.
  virtual bool AcceptsUphillSteps() const { return false; }
  /// The step for the current linearisation into *delta.
  virtual Step ComputeStep(StepSystem& system, std::vector<double>* delta, IterationSummary* it) = 0;
  /// After the step was applied and chi2 evaluated (new_chi2), before it is judged: may
  /// shorten the step (LM halves an undamped one). Returns the chi2 of the step finally
  /// applied; Restore() goes back to the values before the step.
  virtual double Refine(TrialPoint&, std::vector<double>*, double /*chi2*/, double new_chi2, Step*, IterationSummary*) {
    return new_chi2;
  }
  /// The linear solve failed: true where the strategy changed its state so that the next
  /// iteration may succeed (the iteration is then logged as rejected), false to give up.
  virtual bool RetryAfterFailedSolve() { return false; }
  /// A step that lowered chi2 was taken; rho = actual / predicted decrease.
  virtual void StepAccepted(double /*rho*/) {}
  /// A step was not taken (raised chi2, or left a non-finite Jacobian).
  virtual void StepRejected() {}
  /// After a rejection of a step that raised chi2: true where no further step is worth
  /// trying (LM's damping beyond max_lambda); *why says so.
  virtual bool Exhausted(const char** /*why*/) const { return false; }
  /// The settings in use, for the summary ("initial_lambda 0, ...").
  virtual std::string Settings() const { return ""; }
};

using StepStrategyFactory = std::function<std::unique_ptr<StepStrategy>(const SolverOptions&)>;

/// Adds a strategy under a name; throws InvalidArgument where the name is taken (or is
/// "ceres") or the factory is empty.
void RegisterStepStrategy(const std::string& name, StepStrategyFactory make);
/// Removes a strategy added by RegisterStepStrategy; false where there is none. Built-in
/// strategies cannot be removed.
bool RemoveStepStrategy(const std::string& name);
/// A copy of the factory of that name (safe to call while another thread registers or
/// removes strategies); an empty function where none has that name.
StepStrategyFactory FindStepStrategy(const std::string& name);
/// The registered names, sorted.
std::vector<std::string> StepStrategyNames();

/// From a plugin's registration function: adds a step strategy under `name`. The loader
/// commits it with the plugin's variable and factor types and linear solvers, all or nothing,
/// after the same interface-version and fingerprint checks. (A plugin that uses it links
/// tether::solvers.)
void AddStepStrategy(PluginRegistrar& registrar, const std::string& name, StepStrategyFactory make);

}  // namespace tether
