#include "stopping_rules.h"

#include <cmath>
#include <string>

namespace tether {
namespace internal {

namespace {

// Largest |a_i|; NaN if any entry is NaN (so that no tolerance test passes on NaN).
double MaxAbs(const std::vector<double>& a) {
  double m = 0;
  for (double v : a) {
    if (!(std::abs(v) <= m)) m = std::abs(v);
  }
  return m;
}

void Converged(SolverSummary* s, const char* why) {
  s->status = SolverStatus::kConverged;
  s->message = why;
}

}  // namespace

void StoppingRules::AtStart(const std::vector<double>& gradient, SolverSummary* s) const {
  s->status = SolverStatus::kMaxIterations;
  s->message = "reached the maximum number of iterations (" + std::to_string(o_.max_iterations) + ")";
  if (MaxAbs(gradient) < o_.gradient_tolerance) Converged(s, "gradient below gradient_tolerance at the start");
}

bool StoppingRules::MayIterate(double seconds, SolverSummary* s) const {
  if (s->status != SolverStatus::kMaxIterations || s->iterations >= o_.max_iterations) return false;
  if (o_.max_seconds > 0 && seconds > o_.max_seconds) {
    s->status = SolverStatus::kTimeLimit;
    s->message = "reached the time limit";
    return false;
  }
  return true;
}

void StoppingRules::AfterAcceptedStep(double old_chi2, double chi2, const std::vector<double>& gradient,
                                      double step_norm, double x_norm, SolverSummary* s) const {
  if (std::abs(old_chi2 - chi2) <= o_.function_tolerance * old_chi2) {
    Converged(s, "relative decrease of chi2 below function_tolerance");
  } else if (MaxAbs(gradient) < o_.gradient_tolerance) {
    Converged(s, "gradient below gradient_tolerance");
  } else if (step_norm <= o_.parameter_tolerance * (x_norm + o_.parameter_tolerance)) {
    Converged(s, "step below parameter_tolerance");
  }
}

}  // namespace internal
}  // namespace tether
