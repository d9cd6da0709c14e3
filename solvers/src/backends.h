#pragma once
// Internal: the solver back-ends that live in a module of their own, libtether_backends.so
// beside libtether_solvers.so (solvers/backends/): CHOLMOD, SuiteSparseQR and the Ceres
// adapter, with the BLAS and LAPACK they run on. Those libraries (OpenBLAS alone has 16 000
// symbol relocations) took most of the start-up of every tether program, which the graphs
// that the block Cholesky solves never use; the module is loaded at the first call of
// Backends(), through one table of functions. A static build (BUILD_SHARED_LIBS=OFF) links
// the same code into libtether_solvers and the table is at hand.
#include <memory>
#include <vector>

#include "covariance_factor.h"
#include "problem.h"
#include "tether/core/factor_graph.h"
#include "tether/core/linear_solver.h"
#include "tether/core/values.h"
#include "tether/solvers/solver_options.h"

namespace tether {
namespace internal {

/// Bumped whenever the table changes: a module from another build is refused, not called.
constexpr int kBackendTableVersion = 1;

struct BackendTable {
  int version = kBackendTableVersion;
  std::size_t size = sizeof(BackendTable);

  std::unique_ptr<LinearSolver> (*make_cholmod)(std::vector<int> ordering) = nullptr;
  std::unique_ptr<LinearSolver> (*make_spqr)() = nullptr;
  std::unique_ptr<CovarianceFactor> (*make_cholmod_covariance)(const Csc& h, const ColumnNamer& name) = nullptr;
  std::unique_ptr<CovarianceFactor> (*make_qr_covariance)(const Csc& j, const ColumnNamer& name) = nullptr;
  SolverSummary (*optimize_with_ceres)(const FactorGraph& graph, Values* values,
                                       const SolverOptions& options) = nullptr;

  // The BLAS and LAPACK routines tether's own code calls on large dense blocks (blas.h).
  void (*dsyrk)(const char* uplo, const char* trans, const int* n, const int* k, const double* alpha, const double* a,
                const int* lda, const double* beta, double* c, const int* ldc) = nullptr;
  void (*dtrsm)(const char* side, const char* uplo, const char* ta, const char* diag, const int* m, const int* n,
                const double* alpha, const double* a, const int* lda, double* b, const int* ldb) = nullptr;
  void (*dpotrf)(const char* uplo, const int* n, double* a, const int* lda, int* info) = nullptr;
};

/// The back-ends, loaded at the first call (thread-safe). Throws Error naming the module, why
/// it could not be loaded and what to do.
const BackendTable& Backends();

/// Whether Backends() has loaded them (without loading them).
bool BackendsLoaded();

/// Loads a back-end module from `path` and checks its table (the entry point, the version,
/// every function present): nullptr and `why` on failure. What Backends() does with the
/// module beside libtether_solvers.so; tests call it with files that are not the module.
const BackendTable* LoadBackendsFrom(const std::string& path, std::string* why);

}  // namespace internal
}  // namespace tether

/// The module's entry point.
extern "C" const tether::internal::BackendTable* tether_backends_v1();
