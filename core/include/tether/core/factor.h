#pragma once
// Factor: one measurement, a function of a few variables.
//
// A factor computes its error e(x) and, on request, the Jacobian of e with respect to each
// variable's tangent perturbation (the box-plus delta of variable.h). The noise model
// whitens both: the solver minimises sum |R e|^2 ("chi2", as g2o reports it).
//
// Evaluate receives the variables' raw parameters (layouts in variable.h) in key order, and
// writes Jacobians row-major, residual_dim() x TangentDim(type of key k), into jacobians[k]
// (a null jacobians, or a null jacobians[k], means "not needed").
#include <memory>
#include <string>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/key.h"
#include "tether/core/loss_function.h"
#include "tether/core/sqrt_information.h"
#include "tether/core/variable.h"

namespace tether {

class Values;

class Factor {
 public:
  Factor(std::vector<Key> keys, SqrtInformation noise) : keys_(std::move(keys)), noise_(std::move(noise)) {}
  virtual ~Factor() = default;

  /// The registered type name of this factor (for example "BetweenSE2").
  virtual std::string type_name() const = 0;
  /// Residual dimension of the noise model (what the solver allocates for this factor).
  int dim() const { return noise_.dim(); }
  /// The number of error entries Evaluate writes. Override it (built-in factors and
  /// AutoDiffFactor do): the solver refuses a factor whose noise model has another dimension
  /// instead of letting Evaluate write past its buffers. The default trusts the noise model.
  virtual int residual_dim() const { return dim(); }
  /// Type expected for each key, in key order.
  virtual std::vector<VarType> variable_types() const = 0;
  /// Error (not whitened) and its Jacobians; returns false if it cannot be evaluated.
  virtual bool Evaluate(const double* const* params, double* error, double* const* jacobians) const = 0;
  /// A copy of this factor (used to copy graphs).
  virtual std::unique_ptr<Factor> Clone() const = 0;
  /// The measurement in the type's file layout (empty for types without one).
  virtual std::vector<double> Measurement() const { return {}; }
  /// For initialisation: given the parameters of key index `known`, predicts those of key
  /// index `unknown` from the measurement alone. Returns false where the factor cannot
  /// (the default), e.g. for unary factors.
  virtual bool Predict(std::size_t known, const double* known_params, std::size_t unknown,
                       double* unknown_params) const {
    (void)known, (void)known_params, (void)unknown, (void)unknown_params;
    return false;
  }

  /// Whether this factor anchors the graph in the world, as a prior does: where some factor
  /// anchors it, a solve holds no pose fixed to remove the gauge freedom. The default: a
  /// factor on one variable. A prior over several variables (MarginalPrior) says so too.
  virtual bool anchors() const { return keys_.size() == 1; }

  const std::vector<Key>& keys() const { return keys_; }
  const SqrtInformation& noise() const { return noise_; }
  void set_noise(const SqrtInformation& n) { noise_ = n; }
  /// The robust loss on this factor's squared whitened error, or null (plain least squares).
  const LossFunction* loss() const { return loss_.get(); }
  const std::shared_ptr<const LossFunction>& shared_loss() const { return loss_; }
  void set_loss(std::shared_ptr<const LossFunction> loss) { loss_ = std::move(loss); }
  /// Marked as a loop closure (a pose-pose measurement a front-end matched, which may be
  /// wrong), as opposed to odometry. Robust rules and graduated non-convexity select by it;
  /// the mark alone changes nothing in a solve. Reading g2o marks edges between poses whose
  /// ids are not consecutive (ReadOptions::loop_closures).
  bool loop_closure() const { return loop_closure_; }
  void set_loop_closure(bool loop_closure) { loop_closure_ = loop_closure; }

  /// Whitened residual and Jacobians.
  bool Linearize(const double* const* params, double* residual, double* const* jacobians) const;
  /// chi2 = e^T Omega e at the given values; throws InvalidArgument for missing/mistyped keys.
  double Chi2(const Values& values) const;
  /// What the solver minimises for this factor: rho(chi2) with a loss, else chi2.
  double Cost(const Values& values) const;
  /// Throws InvalidArgument unless the keys match variable_types(), are distinct, and the
  /// noise model's dimension is the error's.
  void CheckShape() const;
  /// "BetweenSE2, keys 3, 4": the type and keys, for messages.
  std::string Describe() const;
  /// Gathers parameter pointers for this factor's keys, checking presence and types.
  std::vector<const double*> GatherParams(const Values& values) const;

 private:
  std::vector<Key> keys_;
  SqrtInformation noise_;
  std::shared_ptr<const LossFunction> loss_;
  bool loop_closure_ = false;
};

/// A factor that states its name, residual size and variable types once, at compile time:
///
///   class RangeFactor : public TypedFactor<RangeFactor, 1, SE2d, Eigen::Vector2d> {
///    public:
///     static constexpr const char* kTypeName = "Range2D";
///     RangeFactor(Key pose, Key point, double z, SqrtInformation noise)
///         : TypedFactor({pose, point}, std::move(noise)), z_(z) {}
///     bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override;
///   };
///
/// type_name(), residual_dim(), variable_types() and Clone() come from the base, and
/// DescribeFactor<RangeFactor>(...) (registry.h) fills a registry entry from the same facts.
/// The value types name the variable types (variable.h: SE2d, SE3d, Eigen::Vector2d,
/// Eigen::Vector3d, or a registered type's value type).
template <class Derived, int kDim, class... Vars>
class TypedFactor : public Factor {
 public:
  static_assert(kDim >= 1, "a factor's residual has at least one entry");
  static_assert(sizeof...(Vars) >= 1, "a factor has at least one variable");
  static constexpr int kResidualDim = kDim;
  static constexpr int kNumKeys = sizeof...(Vars);

  /// Throws InvalidArgument where the number of keys is not the number of variable types.
  TypedFactor(std::vector<Key> keys, SqrtInformation noise) : Factor(std::move(keys), std::move(noise)) {
    if (this->keys().size() != sizeof...(Vars)) {
      throw InvalidArgument(std::string(Derived::kTypeName) + " takes " + std::to_string(sizeof...(Vars)) +
                            " keys, got " + std::to_string(this->keys().size()));
    }
  }
  static std::vector<VarType> VariableTypes() { return {VarTypeOf<Vars>()...}; }

  std::string type_name() const override { return Derived::kTypeName; }
  int residual_dim() const override { return kDim; }
  std::vector<VarType> variable_types() const override { return VariableTypes(); }
  std::unique_ptr<Factor> Clone() const override {
    return std::make_unique<Derived>(static_cast<const Derived&>(*this));
  }
};

}  // namespace tether
