// A plugin built out of tether's tree: a prior on the heading of an SE2 pose (for example
// from a compass), e = wrap(theta - z), with an analytic Jacobian.
//
//   EDGE_HEADING_PRIOR_SE2 id theta I11
#include <memory>
#include <string>
#include <vector>

#include "tether/core/factor.h"
#include "tether/plugins/plugin.h"

namespace {

class HeadingPrior : public tether::Factor {
 public:
  HeadingPrior(tether::Key key, double heading, tether::SqrtInformation noise)
      : Factor({key}, noise), heading_(heading) {}

  std::string type_name() const override { return "HeadingPriorSE2"; }
  std::vector<tether::VarType> variable_types() const override { return {tether::VarType::kSE2}; }
  int residual_dim() const override { return 1; }
  std::unique_ptr<tether::Factor> Clone() const override { return std::make_unique<HeadingPrior>(*this); }
  std::vector<double> Measurement() const override { return {heading_}; }

  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override {
    error[0] = tether::WrapAngle(params[0][2] - heading_);  // the short way round
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      // Box-plus adds dtheta to theta and moves only the position with dt.
      jacobians[0][0] = 0.0;
      jacobians[0][1] = 0.0;
      jacobians[0][2] = 1.0;
    }
    return true;
  }

 private:
  double heading_;
};

void RegisterHeadingPrior(tether::PluginRegistrar& registrar) {
  tether::FactorType type;
  type.name = "HeadingPriorSE2";
  type.tag = "EDGE_HEADING_PRIOR_SE2";
  type.dim = 1;
  type.variable_types = {tether::VarType::kSE2};
  type.measurement_size = 1;
  type.measurement_layout = "theta";
  type.make = [](std::vector<tether::Key> keys, const double* m,
                 tether::SqrtInformation noise) -> std::unique_ptr<tether::Factor> {
    return std::make_unique<HeadingPrior>(keys[0], m[0], noise);
  };
  type.measurement = [](const tether::Factor& f) { return f.Measurement(); };
  registrar.AddFactorType(std::move(type));
}

}  // namespace

TETHER_PLUGIN("heading_prior", "0.1.0", RegisterHeadingPrior)
