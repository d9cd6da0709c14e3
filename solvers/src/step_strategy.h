#pragma once
// Internal: a step strategy proposes each iteration's step from the linear system and
// learns from how it went (Minimizer runs the loop). Built in: Gauss-Newton ("gn"),
// Levenberg-Marquardt ("lm") and Powell's dog-leg ("dogleg"), each in its own file; more are
// added by name with RegisterStepStrategy, touching no existing function.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "linear_system.h"
#include "problem.h"
#include "tether/solvers/solver_options.h"

namespace tether {
namespace internal {

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
  /// Whether a step that raises chi2 is taken anyway (Gauss-Newton). The minimizer then
  /// keeps the best values visited and hands them back at the end; otherwise it takes only
  /// steps that lower chi2.
  virtual bool AcceptsUphillSteps() const { return false; }
  /// The step for the current linearisation into *delta.
  virtual Step ComputeStep(LinearSystem& system, std::vector<double>* delta, IterationSummary* it) = 0;
  /// After the step was applied and chi2 evaluated (new_chi2), before it is judged: may
  /// shorten the step (LM halves an undamped one). Returns the chi2 of the step finally
  /// applied; Problem's saved state is the one before the step.
  virtual double Refine(Problem&, std::vector<double>*, double /*chi2*/, double new_chi2, Step*, IterationSummary*) {
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

/// Adds a strategy under a name; throws InvalidArgument where the name is taken.
void RegisterStepStrategy(const std::string& name, StepStrategyFactory make);
/// nullptr where none has that name.
const StepStrategyFactory* FindStepStrategy(const std::string& name);
/// The registered names, sorted.
std::vector<std::string> StepStrategyNames();

// The built-in strategies (gauss_newton.cc, levenberg_marquardt.cc, dogleg.cc).
std::unique_ptr<StepStrategy> MakeGaussNewton(const SolverOptions& options);
std::unique_ptr<StepStrategy> MakeLevenbergMarquardt(const SolverOptions& options);
std::unique_ptr<StepStrategy> MakeDogLeg(const SolverOptions& options);

}  // namespace internal
}  // namespace tether
