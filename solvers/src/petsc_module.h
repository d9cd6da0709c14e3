#pragma once
// Internal: the distributed linear solvers' module, libtether_petsc.so (solvers/petsc/), built
// with TETHER_WITH_MPI and loaded at its first use through one table of functions, as the
// back-ends are (backends.h): a program that never solves across processes never loads MPI or
// PETSc.
#include <memory>
#include <string>

#include "tether/core/linear_solver.h"

namespace tether {
namespace internal {

constexpr int kPetscTableVersion = 1;

struct PetscTable {
  int version = kPetscTableVersion;
  std::size_t size = sizeof(PetscTable);
  /// Starts MPI and PETSc (once) with PETSc's command-line options; false and *why where it
  /// cannot.
  bool (*start)(const std::string& options, int* rank, int* size, std::string* why) = nullptr;
  /// A solver: MUMPS's Cholesky (iterative false) or conjugate gradients with GAMG. Throws
  /// tether::Error before start.
  std::unique_ptr<LinearSolver> (*make_solver)(const LinearSolverOptions& options, bool iterative) = nullptr;
  void (*abort)(int exit_code) = nullptr;
};

}  // namespace internal
}  // namespace tether

/// The module's entry point.
extern "C" const tether::internal::PetscTable* tether_petsc_v1();
