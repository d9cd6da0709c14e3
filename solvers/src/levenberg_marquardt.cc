// Levenberg-Marquardt: (H + lambda D) delta = -g with D = clamp(diag(H)) (Marquardt
// scaling); a step that does not lower chi2 is rejected and the damping grows, an accepted
// one shrinks it by the gain ratio (Nielsen's rule). Below min_lambda the damping is off and
// the step is a Gauss-Newton step, which is halved (max_step_halvings) before damping starts.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "step_strategy.h"

namespace tether {
namespace internal {

namespace {

class LevenbergMarquardt : public StepStrategy {
 public:
  explicit LevenbergMarquardt(const LevenbergMarquardtOptions& o)
      : o_(o), lambda_(o.initial_lambda < o.min_lambda ? 0.0 : o.initial_lambda) {}

  const char* display_name() const override { return "Levenberg-Marquardt"; }
  void Describe(IterationSummary* it) const override { it->lambda = lambda_; }

  Step ComputeStep(StepSystem& system, std::vector<double>* delta, IterationSummary* it) override {
    Step step;
    step.status = system.Solve(lambda_, delta, it);
    if (step.status != LinearSolverStatus::kOk) return step;
    const double dDd = system.ScaledSquaredNorm(*delta);
    step.predicted_decrease = system.PredictedDecrease(*delta, lambda_, dDd, it->reused_factorization);
    return step;
  }

  // An undamped step that overshoots is first tried at half length, a few times, before the
  // damping starts: a chi2 evaluation is far cheaper than the factorisation a damped step
  // needs, and along the very flat directions some datasets have (parking-garage) damping
  // shortens the steps far too much. Along a*d the model predicts -g.d (2a - a^2) at lambda 0.
  double Refine(TrialPoint& p, std::vector<double>* delta, double chi2, double new_chi2, Step* step,
                IterationSummary* it) override {
    if (lambda_ != 0.0) return new_chi2;
    double a = 1.0;
    for (int h = 0; h < o_.max_step_halvings && !(std::isfinite(new_chi2) && new_chi2 < chi2); ++h) {
      p.Restore();
      for (double& d : *delta) d *= 0.5;
      a *= 0.5;
      ++it->step_halvings;
      p.Retract(delta->data());
      new_chi2 = p.Chi2();
    }
    step->predicted_decrease *= 2 * a - a * a;
    it->step_norm *= a;
    return new_chi2;
  }

  bool RetryAfterFailedSolve() override {
    if (!(lambda_ < o_.max_lambda)) return false;
    Grow();
    return true;
  }
  void StepAccepted(double rho) override {
    lambda_ *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3));
    if (lambda_ < o_.min_lambda) lambda_ = 0.0;
    nu_ = 2.0;
  }
  void StepRejected() override { Grow(); }
  bool Exhausted(const char** why) const override {
    *why = "no step lowers chi2 any further (damping reached max_lambda)";
    return lambda_ > o_.max_lambda;
  }
  std::string Settings() const override {
    char buf[160];
    std::snprintf(buf, sizeof buf, "initial_lambda %g, min_lambda %g, max_lambda %g, max_step_halvings %d",
                  o_.initial_lambda, o_.min_lambda, o_.max_lambda, o_.max_step_halvings);
    return buf;
  }

 private:
  // (Re)starts the damping at min_lambda, or doubles its growth factor.
  void Grow() {
    if (lambda_ < o_.min_lambda) {
      lambda_ = o_.min_lambda;
    } else {
      lambda_ *= nu_;
      nu_ *= 2.0;
    }
  }

  LevenbergMarquardtOptions o_;
  double lambda_;  // 0: undamped
  double nu_ = 2.0;
};

}  // namespace

std::unique_ptr<StepStrategy> MakeLevenbergMarquardt(const SolverOptions& options) {
  return std::make_unique<LevenbergMarquardt>(options.lm);
}

}  // namespace internal
}  // namespace tether
