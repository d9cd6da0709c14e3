#pragma once
// Switchable constraints (Sünderhauf and Protzel, "Switchable Constraints for Robust Pose
// Graph SLAM", IROS 2012): a loop closure gets a switch variable s of its own, and its error
// is scaled by psi(s) = clamp(s, 0, 1); a prior pulls s towards 1. The solver can then turn a
// closure off (s -> 0) at the price of the prior, where the closure costs more than that.
//
// | name                 | g2o tag              | keys                 | measurement        |
// |----------------------|----------------------|----------------------|--------------------|
// | (type) Switch        | VERTEX_SWITCH        | one scalar s         |                    |
// | SwitchPrior          | EDGE_SWITCH_PRIOR    | Switch               | prior value        |
// | SwitchableBetweenSE2 | EDGE_SE2_SWITCHABLE  | SE2, SE2, Switch     | x y theta          |
// | SwitchableBetweenSE3 | EDGE_SE3_SWITCHABLE  | SE3, SE3, Switch     | x y z qx qy qz qw  |
//
// The file forms are those of the Vertigo datasets (g2o with its switchable-constraint types).
// SwitchableFactor wraps any factor (built-in or a plugin's) in the same way: the switch key
// comes after the wrapped factor's keys.
//
//   error      e = psi(s) e_inner(x)
//   Jacobians  d e / d x_k = psi(s) J_inner_k,   d e / d s = psi'(s) e_inner
//              (psi' = 1 inside (0, 1), 0 outside; at 0 and 1 the side towards the inside)
//   prior      e = s - prior (information 1 by default: Sünderhauf's Xi = 1)
//
// The switch is an unconstrained scalar; the clamp is in psi. A switch pushed below 0 has no
// pull from its closure there, and its prior brings it back towards the range.
#include <memory>
#include <string>
#include <vector>

#include "tether/core/factor.h"
#include "tether/core/registry.h"

namespace tether {

/// The value of a switch variable (1: the closure counts fully, 0: it is switched off).
struct Switch {
  double value = 1.0;
};

template <>
struct VariableTraits<Switch> {
  static constexpr const char* kName = "Switch";
  static constexpr const char* kTag = "VERTEX_SWITCH";
  static constexpr const char* kParameterNames = "s";
  static constexpr int kAmbient = 1, kTangent = 1;
  template <typename T>
  static void Retract(const T* x, const T* d, T* out) {
    out[0] = x[0] + d[0];
  }
  static void Local(const double* x, const double* y, double* d) { d[0] = y[0] - x[0]; }
  static void Identity(double* x) { x[0] = 1.0; }
  static Switch FromParams(const double* p) { return {p[0]}; }
  static void ToParams(const Switch& s, double* p) { p[0] = s.value; }
};

/// Makes the Switch type known to the process (idempotent) and returns its id. Values can
/// hold a Switch once this has run: DefaultRegistry(), RegisterSwitchableFactors and the
/// constructors of the factors below call it.
VarType InternSwitchType();

/// psi(s) = clamp(s, 0, 1): how much of its closure a switch lets through.
inline double SwitchScale(double s) { return s < 0 ? 0.0 : (s > 1 ? 1.0 : s); }

/// Any factor with its error scaled by psi(s) of a switch (keys: the inner factor's, then the
/// switch). Its type name is "Switchable" + the inner type's name; the noise model, the
/// loop-closure mark and the robust loss are the inner factor's (the loss then applies to the
/// switched error).
class SwitchableFactor : public Factor {
 public:
  /// Throws InvalidArgument for a null inner factor.
  SwitchableFactor(std::unique_ptr<Factor> inner, Key switch_key);
  SwitchableFactor(const SwitchableFactor& other);

  std::string type_name() const override { return "Switchable" + inner_->type_name(); }
  int residual_dim() const override { return inner_->residual_dim(); }
  std::vector<VarType> variable_types() const override;
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  std::unique_ptr<Factor> Clone() const override { return std::make_unique<SwitchableFactor>(*this); }
  std::vector<double> Measurement() const override { return inner_->Measurement(); }
  bool Predict(std::size_t known, const double* known_params, std::size_t unknown,
               double* unknown_params) const override;

  const Factor& inner() const { return *inner_; }
  Key switch_key() const { return keys().back(); }

 private:
  std::unique_ptr<Factor> inner_;
};

/// e = s - prior on a switch (Sünderhauf's prior: value 1, information 1).
class SwitchPrior : public TypedFactor<SwitchPrior, 1, Switch> {
 public:
  static constexpr const char* kTypeName = "SwitchPrior";
  SwitchPrior(Key s, double prior, SqrtInformation noise);
  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
  std::vector<double> Measurement() const override { return {prior_}; }

 private:
  double prior_;
};

/// Registers the Switch variable type, SwitchPrior and the switchable SE2 and SE3 pose-pose
/// factors (tags above) in `registry` (RegisterBuiltinFactors calls this).
void RegisterSwitchableFactors(Registry& registry);

}  // namespace tether
