#include "tether/factors/switchable.h"

#include <Eigen/Geometry>

#include "tether/core/error.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"

namespace tether {

namespace {

const Factor& Checked(const Factor* inner) {
  InternSwitchType();
  if (inner == nullptr) throw InvalidArgument("SwitchableFactor: the inner factor must not be null");
  return *inner;
}

std::vector<Key> WithSwitch(const Factor* inner, Key s) {
  std::vector<Key> keys = Checked(inner).keys();
  keys.push_back(s);
  return keys;
}

}  // namespace

VarType InternSwitchType() {
  static const VarType id = InternVariableType(DescribeVariable<Switch>());
  return id;
}

SwitchableFactor::SwitchableFactor(std::unique_ptr<Factor> inner, Key switch_key)
    : Factor(WithSwitch(inner.get(), switch_key), Checked(inner.get()).noise()), inner_(std::move(inner)) {
  set_loop_closure(inner_->loop_closure());
  set_loss(inner_->shared_loss());  // the inner factor's robust loss, on the switched error
}

SwitchableFactor::SwitchableFactor(const SwitchableFactor& other) : Factor(other), inner_(other.inner_->Clone()) {}

std::vector<VarType> SwitchableFactor::variable_types() const {
  std::vector<VarType> types = inner_->variable_types();
  types.push_back(VarTypeOf<Switch>());
  return types;
}

bool SwitchableFactor::Evaluate(const double* const* params, double* error, double* const* jacobians) const {
  const std::size_t n = inner_->keys().size();
  if (!inner_->Evaluate(params, error, jacobians)) return false;
  const double s = params[n][0];
  const double psi = SwitchScale(s);
  const int m = inner_->residual_dim();
  if (jacobians != nullptr) {
    const std::vector<VarType> types = inner_->variable_types();
    for (std::size_t k = 0; k < n; ++k) {
      if (jacobians[k] == nullptr) continue;
      const int size = m * TangentDim(types[k]);
      for (int i = 0; i < size; ++i) jacobians[k][i] *= psi;
    }
    if (jacobians[n] != nullptr) {
      // One-sided at the ends, towards the inside: a switch at exactly 0 or 1 still feels its closure.
      const double dpsi = (s < 0 || s > 1) ? 0.0 : 1.0;
      for (int i = 0; i < m; ++i) jacobians[n][i] = dpsi * error[i];
    }
  }
  for (int i = 0; i < m; ++i) error[i] *= psi;
  return true;
}

bool SwitchableFactor::Predict(std::size_t known, const double* known_params, std::size_t unknown,
                               double* unknown_params) const {
  const std::size_t n = inner_->keys().size();
  if (known >= n || unknown >= n) return false;
  return inner_->Predict(known, known_params, unknown, unknown_params);
}

SwitchPrior::SwitchPrior(Key s, double prior, SqrtInformation noise)
    : TypedFactor((InternSwitchType(), std::vector<Key>{s}), std::move(noise)), prior_(prior) {}

bool SwitchPrior::Evaluate(const double* const* params, double* error, double* const* jacobians) const {
  error[0] = params[0][0] - prior_;
  if (jacobians != nullptr && jacobians[0] != nullptr) jacobians[0][0] = 1.0;
  return true;
}

namespace {

// A registry entry for a switchable pose-pose factor: keys (pose, pose, switch), the pose-pose
// measurement and information.
FactorType SwitchableEntry(const FactorType& inner, std::string tag) {
  FactorType t;
  t.name = "Switchable" + inner.name;
  t.tag = std::move(tag);
  t.dim = inner.dim;
  t.variable_types = inner.variable_types;
  t.variable_types.push_back(VarTypeOf<Switch>());
  t.measurement_size = inner.measurement_size;
  t.measurement_layout = inner.measurement_layout;
  // Named as the inner type's would be (its last key type's parameter names), not after the
  // switch that now comes last.
  if (t.measurement_layout.empty() && !inner.variable_types.empty() &&
      AmbientDim(inner.variable_types.back()) == inner.measurement_size) {
    t.measurement_layout = Describe(inner.variable_types.back()).parameter_names;
  }
  const FactorMaker make_inner = inner.make;
  t.make = [make_inner](std::vector<Key> keys, const double* m, SqrtInformation noise) -> std::unique_ptr<Factor> {
    const Key s = keys.back();
    keys.pop_back();
    return std::make_unique<SwitchableFactor>(make_inner(std::move(keys), m, std::move(noise)), s);
  };
  t.measurement = [](const Factor& f) { return f.Measurement(); };
  return t;
}

}  // namespace

void RegisterSwitchableFactors(Registry& r) {
  r.RegisterVariable<Switch>();
  r.Register(
      DescribeFactor<SwitchPrior>("EDGE_SWITCH_PRIOR", 1, [](std::vector<Key> k, const double* m, SqrtInformation n) {
        return std::make_unique<SwitchPrior>(k[0], m[0], std::move(n));
      }));
  const FactorType* se2 = r.FindByName(BetweenSE2::kTypeName);
  const FactorType* se3 = r.FindByName(BetweenSE3::kTypeName);
  if (se2 == nullptr || se3 == nullptr) {
    throw InvalidArgument("RegisterSwitchableFactors: register BetweenSE2 and BetweenSE3 first");
  }
  r.Register(SwitchableEntry(*se2, "EDGE_SE2_SWITCHABLE"));
  r.Register(SwitchableEntry(*se3, "EDGE_SE3_SWITCHABLE"));
}

}  // namespace tether
