#pragma once
// Internal: the iteration loop. It knows nothing of any one algorithm: a StepStrategy
// proposes each step, the LinearSystem solves for it, StoppingRules decide when to stop.
// One iteration, in order:
//   1. check the budget (iterations, time)          5. judge it: keep, or restore and reject
//   2. compute a step (the strategy)                6. relinearise and reassemble
//   3. apply it and evaluate chi2                   7. log the iteration
//   4. let the strategy refine it (LM's halving)    8. check the tolerances
#include <chrono>
#include <string>
#include <vector>

#include "linear_system.h"
#include "problem.h"
#include "step_strategy.h"
#include "stopping_rules.h"
#include "tether/core/timing.h"

namespace tether {
namespace internal {

using Clock = std::chrono::steady_clock;

class Minimizer {
 public:
  Minimizer(const SolverOptions& options, Problem* problem, LinearSystem* system, StepStrategy* strategy,
            SolverSummary* summary, Clock::time_point t0);

  /// From the linearised start (chi2) until a stopping rule fires; fills the summary's
  /// status, message, counters, timings and final chi2.
  void Minimize(double chi2);

 private:
  void Start();
  double AgreedSeconds() const;
  bool Iterate();
  IterationSummary BeginIteration() const;
  bool HandleFailedSolve(LinearSolverStatus status, IterationSummary& it);
  double ApplyStep(Step* step, IterationSummary& it);
  bool Keeps(double new_chi2) const;
  void Reject(IterationSummary& it);
  bool RejectUphillStep(IterationSummary& it);
  bool Relinearize(IterationSummary& it, double old_chi2);
  void Diverged(IterationSummary& it, const char* what, double chi2);
  void Log(IterationSummary& it);
  bool StopRequested();
  void Finish();

  const SolverOptions& options_;
  Problem& p_;
  LinearSystem& system_;
  StepStrategy& strategy_;
  SolverSummary& s_;
  StoppingRules stop_;
  Clock::time_point t0_;
  const bool uphill_;  // the strategy takes steps that raise chi2 (then the best visited is kept)
  double chi2_ = 0;
  double best_chi2_ = 0;
  // The factor that could not be evaluated at the last step tried, where one could not.
  std::string step_failure_;
  double x_norm_ = 0;  // |x| before the step, for the parameter tolerance
  std::vector<double> delta_;
  int stop_after_ = -1;  // the iteration after which keep_going returned false (-1: none)
};

}  // namespace internal
}  // namespace tether
