#pragma once
// The normal equations of a graph at given values, H dx = -g with H = J^T J and g = J^T r
// over the whitened factors, built by the same code and in the same form as the solvers build
// them every iteration (a factor with a robust loss weighted as the solvers weight it):
//
//   NormalEquations ne(graph, values, {first_pose});  // H's pattern, once
//   double chi2 = ne.Linearize();                     // residuals and Jacobians at the values
//   ne.Assemble();                                    // H and g from them
//   LinearSolverEntry cholmod;
//   DefaultLinearSolverRegistry().Get("cholmod", &cholmod);
//   std::unique_ptr<LinearSolver> s = cholmod.make({});
//   s->Analyze(ne.H(), ne.BlockSizes());
//   s->Factorize(ne.H());
//
// For a look at the system a solve works on (its pattern, its conditioning), for trying a
// linear solver (a plugin's) on the systems the solvers would give it, and for timing the
// assembly on its own (benchmarks/micro). Marginals (covariance.h) inverts H; Optimize
// (optimizer.h) solves with it.
//
// Columns: the free variables in the order of values.keys(), each a block of its tangent
// dimension (BlockSizes()); the variables no factor uses and the held ones have no column.
// Threads: as SolverOptions::num_threads; H, g and chi2 are bit-identical for any count.
#include <memory>
#include <set>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/linear_solver.h"
#include "tether/core/values.h"

namespace tether {

class NormalEquations {
 public:
  /// Lays out H for `graph` at `values` (copied): every variable of `values` that some factor
  /// uses is free, except graph.fixed() and `held` (for example one pose, the gauge of a graph
  /// with no prior). Throws InvalidArgument where a factor's keys are missing from `values` or
  /// of another type (naming the factor's type and the key), or num_threads is below 1.
  NormalEquations(const FactorGraph& graph, const Values& values, const std::set<Key>& held = {}, int num_threads = 1);
  ~NormalEquations();
  NormalEquations(const NormalEquations&) = delete;
  NormalEquations& operator=(const NormalEquations&) = delete;

  /// The values the system is built at (the copy).
  const Values& values() const;
  /// The free variables in column order, and their tangent dimensions (their sum is H's size).
  std::vector<Key> FreeKeys() const;
  std::vector<int> BlockSizes() const;
  /// H's size: the free variables' tangent dimensions summed.
  int size() const;

  /// Residuals and Jacobians at the values; returns the solvers' objective there (chi2, or
  /// the sum of the robust costs where factors carry a loss), +inf where a factor fails or
  /// gives a value that is not finite.
  double Linearize();
  /// The objective alone (no Jacobians), as Linearize returns it.
  double Chi2() const;
  /// H and g from the last Linearize (zero before the first).
  void Assemble();

  /// H as Assemble left it: size() x size(), the upper triangle with whole diagonal blocks
  /// (LinearSystemForm::kNormalEquations). The arrays live as long as this object; their
  /// values change with each Assemble, the pattern never.
  SparseMatrixView H() const;
  /// g = J^T r as Assemble left it (size() entries).
  const std::vector<double>& g() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tether
