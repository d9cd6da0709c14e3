// Gauss-Newton: every step solves H delta = -g and is taken when chi2 stays finite, even
// where chi2 rises; the minimizer hands back the best values visited.
#include "step_strategy.h"

namespace tether {
namespace internal {

namespace {

class GaussNewton : public StepStrategy {
 public:
  const char* display_name() const override { return "Gauss-Newton"; }
  void Describe(IterationSummary* it) const override { it->lambda = 0; }
  bool AcceptsUphillSteps() const override { return true; }
  Step ComputeStep(StepSystem& system, std::vector<double>* delta, IterationSummary* it) override {
    Step step;
    step.status = system.Solve(0.0, delta, it);
    return step;  // the predicted decrease is not needed: no step is judged by it
  }
};

}  // namespace

std::unique_ptr<StepStrategy> MakeGaussNewton(const SolverOptions&) { return std::make_unique<GaussNewton>(); }

}  // namespace internal
}  // namespace tether
