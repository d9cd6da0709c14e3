#pragma once
// Gauss-Newton and Levenberg-Marquardt over sparse Cholesky (CHOLMOD, Eigen) or QR (SPQR).
//
// The structure (variable ordering, sparsity of H or J, symbolic factorisation) is built
// once per solve and reused by every iteration. Where the graph fixes no variable and has
// no unary factor (prior), the pose with the lowest key is held fixed to remove the gauge
// freedom; the summary says so.
//
// Levenberg-Marquardt solves (H + lambda D) delta = -g with D = diag(H) (clamped), and
// never accepts a step that raises chi2. Gauss-Newton takes every finite step, but
// returns the best values it visited. Non-finite values never reach `values`.
#include "tether/core/factor_graph.h"
#include "tether/core/values.h"
#include "tether/solvers/solver_options.h"

namespace tether {

/// Optimises `values` in place. With options.algorithm == Algorithm::kCeres this is
/// OptimizeWithCeres (ceres_adapter.h). Never throws for numerical trouble: the status says what
/// happened. Throws InvalidArgument only for programming errors (null values).
SolverSummary Optimize(const FactorGraph& graph, Values* values, const SolverOptions& options = {});

}  // namespace tether
