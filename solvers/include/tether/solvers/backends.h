#pragma once
// The solver back-ends that tether loads at their first use: CHOLMOD (linear solvers
// "cholmod", and "auto" where the factor is dense), SuiteSparseQR ("qr") and the Ceres adapter
// (algorithm "ceres"), with the BLAS and LAPACK libraries they run on. They live in
// libtether_backends.so, beside libtether_solvers.so where both are built and installed, so a
// program whose graphs the block Cholesky solves never loads them (and starts in a third of
// the time). Code that uses the Ceres problem builder (ceres_problem.h) directly links
// tether::backends.
#include <string>

namespace tether {

/// Loads the back-ends now (a no-op once loaded). Throws tether::Error naming the module and
/// why it could not be loaded. Solvers that need them call this themselves; a program calls it
/// only to pay the load up front (before timing a solve) or to check an installation.
void LoadSolverBackends();

/// Whether the back-ends are loaded.
bool SolverBackendsLoaded();

}  // namespace tether
