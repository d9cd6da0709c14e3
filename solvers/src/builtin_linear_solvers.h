#pragma once
// Internal: the built-in linear solvers (auto, block, cholmod, ldlt, qr) and their place in the
// process-wide registry (tether/core/linear_solver.h).
#include <memory>
#include <vector>

#include "problem.h"
#include "tether/core/linear_solver.h"

namespace tether {
namespace internal {

/// `ordering`: a fill-reducing permutation of the columns (column k of the factor is column
/// ordering[k] of the matrix) that CHOLMOD takes instead of its own; empty: CHOLMOD orders.
std::unique_ptr<LinearSolver> MakeCholmod(std::vector<int> ordering = {});
std::unique_ptr<LinearSolver> MakeEigenLDLT();
std::unique_ptr<LinearSolver> MakeSpqr();
std::unique_ptr<LinearSolver> MakeBlockCholesky();
/// The default: the block Cholesky on sparse factors of one block size, CHOLMOD otherwise.
std::unique_ptr<LinearSolver> MakeAutoCholesky();

/// "petsc" and "petsc-iterative" where tether is built with TETHER_WITH_MPI (distributed.cc;
/// nothing otherwise): their module is loaded when a solve first makes one.
void RegisterDistributedLinearSolvers(LinearSolverRegistry& r);

/// DefaultLinearSolverRegistry() with the built-in solvers in it (added on the first call,
/// which the loading of tether::solvers itself makes, before any plugin can take a name).
LinearSolverRegistry& LinearSolvers();

/// A view of a Csc's arrays.
inline SparseMatrixView View(const Csc& a) {
  return SparseMatrixView{a.rows, a.cols, a.colptr.data(), a.rowind.data(), a.values.data()};
}

}  // namespace internal
}  // namespace tether
