#pragma once
// The Ceres adapter: solves a tether FactorGraph with Ceres' Levenberg-Marquardt over
// SPARSE_NORMAL_CHOLESKY (SuiteSparse), and summarises the solve in the same SolverSummary the
// native solvers fill. `tether::Optimize` calls it when options.algorithm is
// Algorithm::kCeres ("ceres"; `tether optimize --solver ceres`).
//
// Any factor works, built-in or loaded from a plugin: each becomes a ceres::CostFunction, and
// SE2 and SE3 variables get a ceres::Manifold whose Plus is tether's retraction, so both
// solvers minimise the same objective along the same retraction. How the graph is mapped and
// how the factors' tangent-space Jacobians are handed to Ceres: ceres_problem.h.
//
// Robust kernels: tether's factors have none yet. When they gain one it maps to a
// ceres::LossFunction on the factor's residual block (see CeresProblem); nothing else here
// changes, except that Ceres' cost is then the robustified one, while the chi2 values in the
// summary stay tether's own FactorGraph::Chi2.
//
// Options (SolverOptions), and how they reach Ceres:
// - max_iterations, function_tolerance, gradient_tolerance, parameter_tolerance: Ceres'
//   namesakes (Ceres measures them slightly differently: its function tolerance also ends the
//   solve on a rejected step whose change is that small, and its gradient tolerance applies
//   to |x - Plus(x, -g)|_inf; g is the gradient of chi2 / 2 in both);
// - max_seconds: max_solver_time_in_seconds (0: no limit);
// - callback: called with every Ceres iteration, mapped to IterationSummary: chi2 = 2 * cost,
//   relative_decrease = change of chi2 over chi2 before the step, lambda = 1 / (the trust
//   region radius the step was computed with), step_norm = Ceres' step norm, seconds since
//   OptimizeWithCeres started, accepted = Ceres' step_is_successful (it runs inside
//   ceres::Solve, where OpenMP regions on the calling thread get one thread: CHOLMOD's teams
//   are held to one thread there, see docs/solvers.md);
// - LM damping (options.lm): Ceres' LM regularises with diag(J^T J) / radius, the radius being the inverse
//   of tether's lambda; the radius starts at 1 / max(lm.initial_lambda, lm.min_lambda), never
//   exceeds 1 / lm.min_lambda and the solve ends once it falls below 1 / lm.max_lambda. Ceres cannot
//   switch the damping off altogether, nor halve steps (lm.max_step_halvings is not used);
// - linear_solver must be kCholmod (Ceres' SPARSE_NORMAL_CHOLESKY runs on CHOLMOD); the
//   others are native only and are refused as invalid input.
// Fixed variables are constant blocks; where the graph fixes nothing and has no prior, the
// same gauge pose as in the native solvers is held fixed. Variables no factor uses are left
// out. Fixed and unused variables are never written.
//
// Status: Ceres' CONVERGENCE is kConverged; NO_CONVERGENCE is kMaxIterations or kTimeLimit;
// FAILURE (or a factor that threw, or non-finite final values) is kDiverged, and then the
// start values are kept and the message says why. Bad options or graphs are kInvalidInput
// with values untouched, as natively. initial_chi2 and final_chi2 are FactorGraph::Chi2 of the
// start and final values, comparable with the native solvers' figures.
#include "tether/core/factor_graph.h"
#include "tether/core/values.h"
#include "tether/solvers/solver_options.h"

namespace tether {

/// Optimises `values` in place with Ceres. Never throws for numerical trouble or bad input
/// (the status says what happened); throws InvalidArgument for a null `values`.
SolverSummary OptimizeWithCeres(const FactorGraph& graph, Values* values, const SolverOptions& options = {});

}  // namespace tether
