#pragma once
// One solve spread over the processes of an MPI job: the linear solvers "petsc" (an exact
// sparse Cholesky by MUMPS over every process) and "petsc-iterative" (conjugate gradients with
// PETSc's algebraic multigrid), in a module of their own (libtether_petsc.so) that is built
// only with -DTETHER_WITH_MPI=ON and loaded at its first use. docs/distributed.md says when to
// use them and how to run them.
//
// Every process of the job runs the same program on the same input: each reads the graph,
// keeps all the values and runs the same Levenberg-Marquardt (or Gauss-Newton, dog-leg) loop.
// With more than one process the variables are split by a METIS k-way partition; each process
// linearises only the factors whose first free variable it owns and adds its share of H into
// one PETSc matrix, which MUMPS factorises over all of them; the step comes back to every
// process whole. chi2, g and diag(H) are summed over the processes, and every value a decision
// rests on is then made the first process's on all (ProcessGroup, tether/core/linear_solver.h),
// so that all take the same path.
//
//   tether::StartDistributed("");             // MPI and PETSc up; {rank, size}
//   options.linear_solver = tether::LinearSolverType("petsc");
//   tether::Optimize(graph, &values, options);  // on every process
//   if (tether::CurrentProcess().rank == 0) ... write the result
#include <string>

namespace tether {

struct DistributedProcess {
  int rank = 0;  ///< this process's place in the job, 0 .. size - 1
  int size = 1;  ///< how many processes the job has
};

/// Whether this tether was built with the distributed solvers (TETHER_WITH_MPI).
bool DistributedBuilt();

/// Starts MPI and PETSc once (later calls return the same), with `petsc_options` read as
/// PETSc's command-line options ("-pc_factor_mat_solver_type mumps -mat_mumps_icntl_14 50");
/// they apply to every later solve. Throws tether::Error where tether was built without them,
/// the module cannot be loaded, MPI cannot start or an option is malformed (the message says
/// which). The processes of a job must all call it, with the same options.
DistributedProcess StartDistributed(const std::string& petsc_options = "");

/// This process's place: {0, 1} until StartDistributed.
DistributedProcess CurrentProcess();

/// Ends every process of the job with `exit_code` (MPI_Abort): what a process that fails where
/// the others cannot know (a bad input, a write that failed) calls, so that the job does not
/// wait for it forever. Does nothing before StartDistributed or in a job of one process.
void AbortDistributed(int exit_code);

}  // namespace tether
