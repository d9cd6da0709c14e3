#pragma once
// The building blocks of the Ceres adapter (ceres_adapter.h): a tether FactorGraph as a
// ceres::Problem. Public so that tests, and users who want to drive Ceres themselves (their
// own Solver::Options, extra residual blocks), can use them.
//
// What is mapped
// - Variables: one parameter block per variable that some factor uses, holding a copy of the
//   variable's ambient parameters (layouts in tether/core/variable.h). Variables no factor
//   uses are left out, as in the native solvers. SE2, SE3 and registered types' blocks get a
//   VariableManifold whose Plus is tether's RetractParams, so Ceres and the native solvers
//   step along the same retraction and minimise the same objective; Point2 and Point3 blocks
//   are Euclidean. A registered type's P(x) comes from central differences of its box-plus
//   and L(x) is P's pseudo-inverse: J_a P = J_t L P = J_t holds exactly all the same.
// - Fixed variables: constant parameter blocks.
// - Factors: one FactorCostFunction per factor; its residual is the factor's whitened error,
//   so Ceres' cost is chi2 / 2. A factor that uses one variable twice gets one parameter
//   block for it (Ceres forbids repeating a block) and the sum of the two Jacobians.
// - Robust losses (Factor::loss): a ceres::LossFunction that evaluates the factor's own loss
//   (Ceres's rho of the squared residual norm is tether's), so Ceres' cost is half the sum of
//   rho: the native solvers' objective (FactorGraph::Cost) over 2.
//
// How Jacobians reach Ceres
// Ceres asks a cost function for dr/dx in ambient coordinates (m x a) and right-multiplies it
// by the manifold's PlusJacobian P(x) = d Plus(x, d) / dd at d = 0 (a x t) to obtain the
// tangent Jacobian it actually solves with. tether's factors already produce that tangent
// Jacobian J_t = d r(x (+) d) / dd directly (Factor::Linearize). So FactorCostFunction
// reports the ambient Jacobian J_a = J_t L(x), where L(x) (t x a) is a left inverse of P(x)
// (L P = I). Ceres then forms J_a P = J_t L P = J_t: exactly the matrix the native solvers
// use, with no finite differences and no chain rule through the quaternion. J_a need not be
// the true ambient derivative (for factors that normalise the quaternion they read, as the
// built-in ones do, it is: their error does not change along q itself, and J_a q = 0 too);
// any difference lies in directions that leave the manifold, which Ceres never uses because
// it always multiplies by P. P has orthogonal blocks, so L is cheap:
//   SE2: P = diag(R, 1),  L = P^T;
//   SE3: P = diag(R, Q) with Q = d q (x) Exp(w) / dw (4 x 3, Q^T Q = I / 4),  L = diag(R^T, 4 Q^T).
// The same L is the manifold's MinusJacobian (the derivative of box-minus at y = x).
#include <ceres/cost_function.h>
#include <ceres/manifold.h>
#include <ceres/problem.h>

#include <algorithm>
#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/values.h"

namespace tether {

/// P(x) = d RetractParams(x, d) / dd at d = 0, row-major AmbientDim x TangentDim.
void RetractJacobian(VarType type, const double* x, double* jacobian);
/// L(x), a left inverse of RetractJacobian (L P = I), row-major TangentDim x AmbientDim.
void RetractJacobianLeftInverse(VarType type, const double* x, double* jacobian);

/// A tether variable type as a Ceres manifold: Plus is RetractParams, Minus is LocalParams.
class VariableManifold : public ceres::Manifold {
 public:
  explicit VariableManifold(VarType type) : type_(type) {}
  int AmbientSize() const override { return AmbientDim(type_); }
  int TangentSize() const override { return TangentDim(type_); }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
  VarType type() const { return type_; }

 private:
  VarType type_;
};

/// Collects the first exception a factor threw while Ceres evaluated it (Ceres' evaluation
/// may run on several threads and must not see exceptions). Thread-safe.
class EvaluationErrors {
 public:
  void Record(const std::string& what);
  bool any() const { return any_.load(std::memory_order_relaxed); }
  std::string first() const;

 private:
  std::atomic<bool> any_{false};
  mutable std::mutex mutex_;
  std::string first_;
};

/// One tether Factor as a ceres::CostFunction: one parameter block per distinct key, of the
/// variable's ambient size; residual = whitened error; Jacobians as explained above.
/// A factor that throws has the exception recorded in `errors` (if not null) and reports a
/// failed evaluation to Ceres.
class FactorCostFunction : public ceres::CostFunction {
 public:
  FactorCostFunction(const Factor* factor, EvaluationErrors* errors);
  bool Evaluate(const double* const* parameters, double* residuals, double** jacobians) const override;
  /// The keys of the parameter blocks, in order (the factor's keys without repeats).
  const std::vector<Key>& block_keys() const { return block_keys_; }

 private:
  const Factor* factor_;
  EvaluationErrors* errors_;
  std::vector<VarType> types_;   // per key of the factor
  std::vector<int> block_of_;    // per key of the factor: its parameter block
  std::vector<Key> block_keys_;  // per parameter block
  std::vector<VarType> block_types_;
  std::vector<int> tangent_offset_;  // per key of the factor: its Jacobian's first tangent column
  int tangent_total_ = 0;
};

/// A FactorGraph and (a copy of) its Values as a ceres::Problem. The graph must outlive it.
class CeresProblem {
 public:
  /// Variables in `fixed` become constant blocks. Throws InvalidArgument naming the factor
  /// for a factor whose keys or noise do not match its type, or that refers to a missing or
  /// mistyped variable.
  CeresProblem(const FactorGraph& graph, const Values& values, const std::set<Key>& fixed);
  CeresProblem(const CeresProblem&) = delete;
  CeresProblem& operator=(const CeresProblem&) = delete;

  ceres::Problem& problem() { return problem_; }
  /// Variables in the problem (used by some factor), in the Values' insertion order.
  const std::vector<Key>& keys() const { return keys_; }
  /// The parameter block of `k`, or nullptr where k is not in the problem.
  double* Block(Key k);
  bool IsConstant(Key k) const;

  int num_free() const { return num_free_; }
  int num_constant() const { return static_cast<int>(keys_.size()) - num_free_; }
  int tangent_dim() const { return tangent_dim_; }
  int num_residuals() const { return num_residuals_; }
  /// chi2 of factors without keys, which Ceres cannot hold (they are constant).
  double keyless_chi2() const { return keyless_chi2_; }

  /// Copies the free variables' blocks into `values`; fixed and unused variables are not
  /// touched. Returns false, and writes nothing, if any free block is not finite.
  bool WriteBack(Values* values) const;
  /// Puts the values the problem was built from back into the blocks.
  void ResetBlocks() { std::copy(start_.begin(), start_.end(), params_.begin()); }

  /// Exceptions thrown by factors during evaluation.
  const EvaluationErrors& errors() const { return errors_; }

 private:
  static ceres::Problem::Options ProblemOptions();

  std::map<VarType, std::unique_ptr<VariableManifold>> manifolds_;  // one per non-point type in use
  EvaluationErrors errors_;
  std::vector<Key> keys_;
  std::vector<VarType> types_;
  std::vector<std::size_t> offsets_;
  std::vector<char> constant_;
  std::unordered_map<Key, int> index_;
  std::vector<double> params_, start_;
  int num_free_ = 0, tangent_dim_ = 0, num_residuals_ = 0;
  double keyless_chi2_ = 0;
  ceres::Problem problem_;  // last: destroyed first, before the manifolds it points to
};

}  // namespace tether
