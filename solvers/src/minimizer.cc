#include "minimizer.h"

#include <cmath>
#include <string>

namespace tether {
namespace internal {

Minimizer::Minimizer(const SolverOptions& options, Problem* problem, LinearSystem* system, StepStrategy* strategy,
                     SolverSummary* summary, Clock::time_point t0)
    : options_(options),
      p_(*problem),
      system_(*system),
      strategy_(*strategy),
      s_(*summary),
      stop_(options),
      t0_(t0),
      uphill_(strategy->AcceptsUphillSteps()),
      delta_(problem->tangent_dim(), 0.0) {}

void Minimizer::Minimize(double chi2) {
  system_.Agree(&chi2, 1);
  chi2_ = best_chi2_ = chi2;
  Start();
  while (!StopRequested() && stop_.MayIterate(AgreedSeconds(), &s_) && Iterate()) {
  }
  StopRequested();  // a request during the last iteration, where no other rule ended the solve
  Finish();
}

// The seconds since the start, the same on every process where the solve spans several (each
// stops at the same iteration under max_seconds).
double Minimizer::AgreedSeconds() const {
  double seconds = SecondsSince(t0_);
  system_.Agree(&seconds, 1);
  return seconds;
}

// Assembles the first system and logs iteration 0. The start is saved: Gauss-Newton keeps
// the best state visited in the save slot, the others the state before each step.
void Minimizer::Start() {
  p_.Save();
  const Clock::time_point tl = Clock::now();
  system_.Assemble();
  s_.linearize_seconds += SecondsSince(tl);
  IterationSummary it0;
  it0.chi2 = chi2_;
  strategy_.Describe(&it0);
  Log(it0);
  stop_.AtStart(system_.gradient(), &s_);
}

// One iteration; false where it ended the solve.
bool Minimizer::Iterate() {
  IterationSummary it = BeginIteration();
  Step step = strategy_.ComputeStep(system_, &delta_, &it);
  if (step.status != LinearSolverStatus::kOk) return HandleFailedSolve(step.status, it);
  const double new_chi2 = ApplyStep(&step, it);
  if (uphill_ && !std::isfinite(new_chi2)) {
    Diverged(it, "chi2 became non-finite after a ", chi2_);
    return false;
  }
  if (!Keeps(new_chi2)) {
    // Named before the step is taken back: where a step cannot be evaluated, say which factor.
    if (std::isfinite(new_chi2)) {
      step_failure_.clear();
    } else {
      step_failure_ = p_.DescribeNonFinite();
    }
    return RejectUphillStep(it);
  }
  step_failure_.clear();
  // The gain ratio: the decrease of chi2 over the linear model's prediction of it.
  const double rho = step.predicted_decrease > 0 ? (chi2_ - new_chi2) / step.predicted_decrease : 0.0;
  if (!uphill_) strategy_.StepAccepted(rho);
  const double old_chi2 = chi2_;
  // Not relinearised: the step was taken back (the solve goes on) or the solve diverged.
  if (!Relinearize(it, old_chi2)) return s_.status == SolverStatus::kMaxIterations;
  ++s_.accepted_iterations;
  if (uphill_ && chi2_ < best_chi2_) {
    best_chi2_ = chi2_;
    p_.Save();
  }
  it.chi2 = chi2_;
  Log(it);
  stop_.AfterAcceptedStep(old_chi2, chi2_, system_.gradient(), it.step_norm, x_norm_, &s_);
  return true;
}

IterationSummary Minimizer::BeginIteration() const {
  ++s_.iterations;
  IterationSummary it;
  it.iteration = s_.iterations;
  strategy_.Describe(&it);
  return it;
}

// The linear solve failed: the strategy may retry with other settings (LM: more damping),
// else the solve ends saying why.
bool Minimizer::HandleFailedSolve(LinearSolverStatus status, IterationSummary& it) {
  if (strategy_.RetryAfterFailedSolve()) {
    it.accepted = false;
    it.chi2 = chi2_;
    Log(it);
    return true;
  }
  if (status == LinearSolverStatus::kFailed) {
    s_.status = SolverStatus::kDiverged;
    s_.message = std::string("the ") + ToString(options_.linear_solver) +
                 " factorisation failed (out of memory or numerical trouble); try another --linear solver";
    return false;
  }
  s_.status = SolverStatus::kRankDeficient;
  s_.message = std::string("the linear system is singular (") +
               (status == LinearSolverStatus::kNotPositiveDefinite ? "not positive definite" : "rank deficient") +
               "): some variables are not constrained; fix a pose, add a prior, or check that the graph "
               "is connected";
  return false;
}

// Moves the values by the step (saving them first where the step may be taken back) and
// returns chi2 there, after the strategy's refinement.
double Minimizer::ApplyStep(Step* step, IterationSummary& it) {
  double step2 = 0;
  for (double d : delta_) step2 += d * d;
  it.step_norm = std::sqrt(step2);
  x_norm_ = p_.ParameterNorm();
  if (!uphill_) p_.Save();
  p_.Retract(delta_.data());
  const Clock::time_point tl = Clock::now();
  double new_chi2 = p_.Chi2();
  new_chi2 = strategy_.Refine(p_, &delta_, chi2_, new_chi2, step, &it);
  s_.linearize_seconds += SecondsSince(tl);
  it.relative_decrease = (chi2_ - new_chi2) / chi2_;
  return new_chi2;
}

bool Minimizer::Keeps(double new_chi2) const { return uphill_ || (std::isfinite(new_chi2) && new_chi2 < chi2_); }

// Logs the iteration as rejected and tells the strategy.
void Minimizer::Reject(IterationSummary& it) {
  it.accepted = false;
  it.chi2 = chi2_;
  Log(it);
  strategy_.StepRejected();
}

bool Minimizer::RejectUphillStep(IterationSummary& it) {
  p_.Restore();
  Reject(it);
  const char* why = nullptr;
  if (strategy_.Exhausted(&why)) {
    if (!step_failure_.empty()) {
      s_.status = SolverStatus::kInvalidInput;
      s_.message = "no step could be evaluated (" + std::string(why) + "): at the last step tried, " + step_failure_ +
                   "; check that factor (its error must be finite near the current values)";
      return false;
    }
    s_.status = SolverStatus::kConverged;
    s_.message = why;
    return false;
  }
  return true;
}

// Linearises at the new values and assembles the next system. A finite cost with a
// non-finite Jacobian cannot be built on: the step is taken back (or, where steps are never
// taken back, the solve ends).
bool Minimizer::Relinearize(IterationSummary& it, double old_chi2) {
  const Clock::time_point tl = Clock::now();
  chi2_ = p_.Linearize();
  if (!p_.jacobian_finite()) {
    if (uphill_) {
      Diverged(it, "the Jacobian became non-finite after a ", old_chi2);
      return false;
    }
    p_.Restore();
    const double again = p_.Linearize();
    if (!std::isfinite(again) || !p_.jacobian_finite()) {
      // It evaluated here before: a factor whose result is not a function of its variables'
      // values alone (a user's factor that changed, or failed part-way through).
      std::string where = p_.DescribeNonFinite();
      s_.status = SolverStatus::kInvalidInput;
      s_.message = "a factor no longer evaluates at values where it did before" +
                   (where.empty() ? std::string() : ": " + where) +
                   "; a factor's error and Jacobians must depend on its variables' values alone";
      it.accepted = false;
      it.chi2 = old_chi2;
      Log(it);
      chi2_ = old_chi2;
      return false;
    }
    system_.Assemble();
    s_.linearize_seconds += SecondsSince(tl);
    chi2_ = old_chi2;
    Reject(it);
    return false;
  }
  system_.Assemble();
  s_.linearize_seconds += SecondsSince(tl);
  return true;
}

void Minimizer::Diverged(IterationSummary& it, const char* what, double chi2) {
  s_.status = SolverStatus::kDiverged;
  s_.message = std::string(what) + strategy_.display_name() + " step";
  // At the values the step reached: name the factor, so that one that fails there (a user's
  // factor undefined beyond some region) is found.
  const std::string where = p_.DescribeNonFinite();
  if (!where.empty()) s_.message += " (" + where + ")";
  s_.message += "; try --solver lm";
  it.accepted = false;
  it.chi2 = chi2;
  Log(it);
}

void Minimizer::Log(IterationSummary& it) {
  it.seconds = SecondsSince(t0_);
  s_.log.push_back(it);
  if (options_.callback) options_.callback(it);
  if (options_.keep_going && stop_after_ < 0 && !options_.keep_going(it)) stop_after_ = it.iteration;
}

// The solve is still running (status kMaxIterations until a rule says otherwise) and keep_going
// asked to stop: status kStopped.
bool Minimizer::StopRequested() {
  if (stop_after_ < 0) return false;
  if (s_.status == SolverStatus::kMaxIterations && s_.iterations < options_.max_iterations) {
    s_.status = SolverStatus::kStopped;
    s_.message = "stopped by keep_going after iteration " + std::to_string(stop_after_);
  }
  return true;
}

// Where steps that raise chi2 were taken, hands back the best state visited.
void Minimizer::Finish() {
  if (uphill_ && chi2_ > best_chi2_) {
    p_.Restore();
    chi2_ = best_chi2_;
    if (s_.status != SolverStatus::kConverged) s_.message += "; returned the best values visited";
  }
  if (uphill_ && s_.status == SolverStatus::kDiverged) {
    p_.Restore();
    chi2_ = best_chi2_;
  }
  const LinearSolveStats& ls = system_.stats();
  s_.factorize_seconds += ls.factorize_seconds;
  s_.solve_seconds += ls.solve_seconds;
  s_.last_factorize_seconds = ls.last_factorize_seconds;
  s_.factorizations += ls.factorizations;
  s_.linear_solver_iterations += ls.iterative_iterations;
  s_.final_chi2 = chi2_;
  s_.total_seconds = SecondsSince(t0_);
}

}  // namespace internal
}  // namespace tether
