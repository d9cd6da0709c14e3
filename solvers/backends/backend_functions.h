#pragma once
// Internal to libtether_backends.so: the functions its table (../src/backends.h) hands to
// libtether_solvers. They live in a namespace of their own so that they never resolve to
// libtether_solvers' forwarders of the same name.
#include <memory>
#include <vector>

#include "covariance_factor.h"
#include "problem.h"
#include "tether/core/factor_graph.h"
#include "tether/core/linear_solver.h"
#include "tether/core/values.h"
#include "tether/solvers/solver_options.h"

namespace tether::backends {

std::unique_ptr<LinearSolver> MakeCholmod(std::vector<int> ordering);
std::unique_ptr<LinearSolver> MakeSpqr();
std::unique_ptr<internal::CovarianceFactor> MakeCholmodCovariance(const internal::Csc& h,
                                                                  const internal::ColumnNamer& name);
std::unique_ptr<internal::CovarianceFactor> MakeQrCovariance(const internal::Csc& j, const internal::ColumnNamer& name);
SolverSummary OptimizeWithCeres(const FactorGraph& graph, Values* values, const SolverOptions& options);

}  // namespace tether::backends
