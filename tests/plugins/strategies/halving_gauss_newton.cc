// A test plugin that adds a step strategy: Gauss-Newton whose step is halved (up to 20 times)
// until it lowers chi2, registered as "gn-halving" beside a small factor type. Built against
// tether::solvers, the way a plugin that adds step strategies is.
#include <cmath>
#include <memory>

#include "../broken/point_prior_type.h"
#include "tether/plugins/plugin.h"
#include "tether/solvers/step_strategy.h"

namespace {

class HalvingGaussNewton : public tether::StepStrategy {
 public:
  const char* display_name() const override { return "Gauss-Newton with halving"; }
  void Describe(tether::IterationSummary* it) const override { it->lambda = 0; }
  tether::Step ComputeStep(tether::StepSystem& system, std::vector<double>* delta,
                           tether::IterationSummary* it) override {
    tether::Step step;
    step.status = system.Solve(0.0, delta, it);
    if (step.status == tether::LinearSolverStatus::kOk)
      step.predicted_decrease = system.PredictedDecrease(*delta, 0, 0, false);
    return step;
  }
  double Refine(tether::TrialPoint& p, std::vector<double>* delta, double chi2, double new_chi2, tether::Step* step,
                tether::IterationSummary* it) override {
    for (int h = 0; h < 20 && !(std::isfinite(new_chi2) && new_chi2 < chi2); ++h) {
      p.Restore();
      for (double& d : *delta) d *= 0.5;
      step->predicted_decrease *= 0.75;  // -g.d (2a - a^2) at a = 1/2 of the previous step's
      it->step_norm *= 0.5;
      ++it->step_halvings;
      p.Retract(delta->data());
      new_chi2 = p.Chi2();
    }
    return new_chi2;
  }
};

void Register(tether::PluginRegistrar& r) {
  r.AddFactorType(tether_test::PointPriorType(STRATEGY_PLUGIN_TYPE, STRATEGY_PLUGIN_TAG));
  tether::AddStepStrategy(r, STRATEGY_NAME,
                          [](const tether::SolverOptions&) { return std::make_unique<HalvingGaussNewton>(); });
}

}  // namespace

TETHER_PLUGIN(STRATEGY_PLUGIN_NAME, "1.0.0", Register)
