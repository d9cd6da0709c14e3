#pragma once
// Options and results of the nonlinear solvers, in the spirit of Ceres' Solver::Options and
// Solver::Summary: plain structs with documented defaults, validated by IsValid.
#include <functional>
#include <string>
#include <vector>

#include "tether/core/key.h"

namespace tether {

enum class Algorithm {
  kGaussNewton,
  kLevenbergMarquardt,
  kCeres,  ///< Ceres' Levenberg-Marquardt through the Ceres adapter (ceres_adapter.h)
};
enum class LinearSolverType {
  kCholmod,    ///< CHOLMOD supernodal Cholesky of H = J^T J (default)
  kEigenLDLT,  ///< Eigen SimplicialLDLT of H (no SuiteSparse needed at run time)
  kQR,         ///< SuiteSparseQR on the Jacobian J itself (better conditioned, slower)
};
enum class SolverStatus {
  kConverged,      ///< a tolerance was met
  kMaxIterations,  ///< max_iterations reached first
  kTimeLimit,      ///< max_seconds reached first
  kDiverged,       ///< chi2 became non-finite or grew without bound; last good values kept
  kRankDeficient,  ///< the linear system is singular (gauge not fixed, disconnected graph)
  kInvalidInput,   ///< options or graph invalid (message says why); values untouched
};

// Names used by the CLI and reports: "gn", "lm", "ceres"; "cholmod", "ldlt", "qr"; "converged", ...
const char* ToString(Algorithm a);
const char* ToString(LinearSolverType t);
const char* ToString(SolverStatus s);
bool FromString(const std::string& s, Algorithm* a);
bool FromString(const std::string& s, LinearSolverType* t);
bool FromString(const std::string& s, SolverStatus* st);

/// One row of the iteration log.
struct IterationSummary {
  int iteration = 0;             ///< 0 is the initial state
  double chi2 = 0;               ///< chi2 after this iteration (of the accepted state)
  double relative_decrease = 0;  ///< (chi2_before - chi2_after) / chi2_before of the tried step
  double lambda = 0;             ///< LM damping used for the step (0 for GN)
  double step_norm = 0;          ///< |delta| of the tried step
  double seconds = 0;            ///< since the solve started
  bool accepted = true;          ///< LM: whether the step was kept
  int step_halvings = 0;         ///< LM: times an undamped step was halved (max_step_halvings)
  /// The step was solved with the factorisation of an earlier H and conjugate gradients
  /// (max_reuse_iterations) instead of a new factorisation.
  bool reused_factorization = false;
  /// Conjugate-gradient iterations of that solve (0 where the earlier factorisation's own
  /// solve was accurate enough, or where H was factorised afresh).
  int cg_iterations = 0;
};

struct SolverOptions {
  Algorithm algorithm = Algorithm::kLevenbergMarquardt;
  LinearSolverType linear_solver = LinearSolverType::kCholmod;
  int max_iterations = 100;
  /// Stop when an accepted step lowers chi2 by less than this fraction (docs/solvers.md
  /// has the measurements behind the default).
  double function_tolerance = 1e-8;
  /// Stop when max |g_i| (gradient of chi2 / 2 in tangent coordinates) is below this.
  double gradient_tolerance = 1e-10;
  /// Stop when |delta| <= parameter_tolerance * (|x| + parameter_tolerance).
  double parameter_tolerance = 1e-10;
  /// Wall-clock limit in seconds (0: none).
  double max_seconds = 0;
  /// LM: initial damping, relative to the diagonal of H (Marquardt scaling). 0: the first
  /// step is a Gauss-Newton step, and damping starts only where a step is rejected. See
  /// docs/solvers.md for the measurements behind the defaults.
  double initial_lambda = 0;
  /// LM: damping below this is switched off (the step is a Gauss-Newton step); a rejected
  /// undamped step restarts the damping here. Some public datasets have directions H barely
  /// constrains (ais2klinik): damping of even 1e-9 of diag(H) shortens the steps along them
  /// tenfold and turns 7 iterations into 30.
  double min_lambda = 1e-9;
  /// LM: how many times an undamped step that raises chi2 is halved and tried again before
  /// damping starts. One halving takes parking-garage from its chordal start in 5 iterations
  /// instead of 14; more halvings cost MIT from its file start 9 iterations.
  int max_step_halvings = 1;
  /// LM: give up (converged: no step lowers chi2) when lambda exceeds this.
  double max_lambda = 1e16;
  /// Threads that evaluate the factors and assemble H and g (gn and lm; 1 to 256). The
  /// results are bit-identical for any number. Default 1: the factorisation, not the
  /// assembly, dominates a solve (CHOLMOD's BLAS has threads of its own), and tether is
  /// often run several times at once (tests, benchmarks, a batch); docs/solvers.md has the
  /// measurements.
  int num_threads = 1;
  /// cholmod and ldlt: the step is first solved by conjugate gradients preconditioned with
  /// the factorisation of an earlier H, at most this many iterations, and H is factorised
  /// afresh only where that does not converge (to 1e-3 of the step in the H-norm, as estimated
  /// with the earlier factorisation; the linear model's decrease is then within about 1e-6). Near the optimum H hardly
  /// changes and a few iterations replace a factorisation; 0 factorises every step. docs/solvers.md has the
  /// measurements behind the default.
  int max_reuse_iterations = 8;
  /// Called after every iteration (and once for iteration 0).
  std::function<void(const IterationSummary&)> callback;

  bool IsValid(std::string* why) const;
};

struct SolverSummary {
  SolverStatus status = SolverStatus::kInvalidInput;
  std::string message;  ///< why it stopped, in words
  Algorithm algorithm = Algorithm::kLevenbergMarquardt;
  LinearSolverType linear_solver = LinearSolverType::kCholmod;
  double initial_chi2 = 0;
  double final_chi2 = 0;
  int iterations = 0;  ///< iterations tried (accepted or not)
  int accepted_iterations = 0;
  int factorizations = 0;  ///< numeric factorisations (iterations less those that reused one)
  double total_seconds = 0;
  double setup_seconds = 0;      ///< symbolic analysis and structure
  double linearize_seconds = 0;  ///< evaluating factors and assembling
  double factorize_seconds = 0;  ///< numeric factorisations
  double solve_seconds = 0;      ///< solving for the step: triangular solves, and the conjugate
                                 ///< gradients of steps that reuse a factorisation (tried or not)
  /// The last numeric factorisation alone (the final H has the same pattern and cost):
  /// factorising it once per iteration is the floor of factorize_seconds.
  double last_factorize_seconds = 0;
  int num_variables = 0;  ///< free variables
  int num_fixed = 0;      ///< variables held constant
  int num_factors = 0;
  int num_residuals = 0;
  int tangent_dim = 0;  ///< columns of J
  bool gauge_fixed_automatically = false;
  Key gauge_key = 0;  ///< the variable fixed automatically, if any
  std::vector<IterationSummary> log;

  bool IsSolutionUsable() const {
    return status == SolverStatus::kConverged || status == SolverStatus::kMaxIterations ||
           status == SolverStatus::kTimeLimit;
  }
  /// One line: status, chi2 before and after, iterations, time.
  std::string BriefReport() const;
  /// Several lines: problem size, settings, timings and why it stopped.
  std::string FullReport() const;
};

}  // namespace tether
