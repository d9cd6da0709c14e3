#pragma once
// Options and results of the nonlinear solvers, in the spirit of Ceres' Solver::Options and
// Solver::Summary: plain structs with documented defaults, validated by IsValid.
#include <functional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "tether/core/enum_names.h"
#include "tether/core/key.h"
#include "tether/core/linear_solver.h"

namespace tether {

/// A step strategy by the name it is registered under: "gn" (Gauss-Newton), "lm"
/// (Levenberg-Marquardt, the default), "dogleg" (Powell's dog-leg), "ceres" (Ceres'
/// Levenberg-Marquardt through the Ceres adapter, ceres_adapter.h). Once an enum; now a name,
/// so that more can be registered (step_strategy.h) without touching existing code. The
/// constants name the built-in ones.
class Algorithm {
 public:
  Algorithm() : name_("lm") {}
  explicit Algorithm(std::string name) : name_(std::move(name)) {}
  const std::string& name() const { return name_; }
  bool operator==(const Algorithm& o) const { return name_ == o.name_; }
  bool operator!=(const Algorithm& o) const { return name_ != o.name_; }

  static const Algorithm kGaussNewton, kLevenbergMarquardt, kDogLeg, kCeres;

 private:
  std::string name_;
};
inline const Algorithm Algorithm::kGaussNewton{"gn"};
inline const Algorithm Algorithm::kLevenbergMarquardt{"lm"};
inline const Algorithm Algorithm::kDogLeg{"dogleg"};
inline const Algorithm Algorithm::kCeres{"ceres"};

/// A linear solver by the name it is registered under (tether/core/linear_solver.h):
/// "auto" (the default: the block Cholesky of H = J^T J where its factor is sparse and the
/// variables' blocks have one size, CHOLMOD otherwise), "block" (tether's own sparse Cholesky
/// on the variables' blocks), "cholmod" (CHOLMOD's Cholesky of H, simplicial or supernodal),
/// "ldlt" (Eigen's SimplicialLDLT of H, no SuiteSparse needed at run time), "qr"
/// (SuiteSparseQR on J itself: better conditioned, slower), or one a plugin registered (the
/// example plugin's "pcg"). docs/solvers.md compares them. Once an enum, like Algorithm.
class LinearSolverType {
 public:
  LinearSolverType() : name_("auto") {}
  explicit LinearSolverType(std::string name) : name_(std::move(name)) {}
  const std::string& name() const { return name_; }
  bool operator==(const LinearSolverType& o) const { return name_ == o.name_; }
  bool operator!=(const LinearSolverType& o) const { return name_ != o.name_; }

  static const LinearSolverType kAuto, kBlock, kCholmod, kEigenLDLT, kQR;

 private:
  std::string name_;
};
inline const LinearSolverType LinearSolverType::kAuto{"auto"};
inline const LinearSolverType LinearSolverType::kBlock{"block"};
inline const LinearSolverType LinearSolverType::kCholmod{"cholmod"};
inline const LinearSolverType LinearSolverType::kEigenLDLT{"ldlt"};
inline const LinearSolverType LinearSolverType::kQR{"qr"};

/// Whether the ceres algorithm runs with this linear solver: Ceres factorises with its own
/// SPARSE_NORMAL_CHOLESKY over SuiteSparse, which "auto" (the default) and "cholmod" name.
inline bool CeresRunsWith(const LinearSolverType& l) {
  return l == LinearSolverType::kCholmod || l == LinearSolverType::kAuto;
}

enum class SolverStatus {
  kConverged,      ///< a tolerance was met
  kMaxIterations,  ///< max_iterations reached first
  kTimeLimit,      ///< max_seconds reached first
  kDiverged,       ///< chi2 became non-finite or grew without bound; last good values kept
  kRankDeficient,  ///< the linear system is singular (gauge not fixed, disconnected graph)
  kInvalidInput,   ///< options or graph invalid (message says why); values untouched
  kStopped,        ///< SolverOptions::keep_going returned false; the values of the last iteration it saw
};
inline constexpr EnumName<SolverStatus> kSolverStatusNames[] = {{SolverStatus::kConverged, "converged"},
                                                                {SolverStatus::kMaxIterations, "max-iterations"},
                                                                {SolverStatus::kTimeLimit, "time-limit"},
                                                                {SolverStatus::kDiverged, "diverged"},
                                                                {SolverStatus::kRankDeficient, "rank-deficient"},
                                                                {SolverStatus::kInvalidInput, "invalid-input"},
                                                                {SolverStatus::kStopped, "stopped"}};
constexpr const auto& EnumNames(SolverStatus) { return kSolverStatusNames; }

// Names used by the CLI and reports: "gn", "lm", "dogleg", "ceres"; "cholmod", "ldlt", "qr";
// "converged", ... FromString accepts the names registered at the time of the call (a
// plugin's linear solver once the plugin is loaded). ToString of an Algorithm or
// LinearSolverType is its name(), valid while that object lives.
const char* ToString(const Algorithm& a);
const char* ToString(const LinearSolverType& t);
bool FromString(const std::string& s, Algorithm* a);
bool FromString(const std::string& s, LinearSolverType* t);
/// The registered names, comma-separated ("dogleg, gn, lm, ceres"), for messages.
std::string AlgorithmNames();
std::string LinearSolverNames();

/// One row of the iteration log.
struct IterationSummary {
  int iteration = 0;             ///< 0 is the initial state
  double chi2 = 0;               ///< chi2 after this iteration (of the accepted state)
  double relative_decrease = 0;  ///< (chi2_before - chi2_after) / chi2_before of the tried step
  double lambda = 0;             ///< LM damping used for the step (0 for GN and dog-leg)
  double trust_radius = 0;       ///< dog-leg: the trust region's radius the step was computed with
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

/// Levenberg-Marquardt (options.lm); the Ceres adapter maps them onto Ceres' LM as well.
struct LevenbergMarquardtOptions {
  /// Initial damping, relative to the diagonal of H (Marquardt scaling). 0: the first step is
  /// a Gauss-Newton step, and damping starts only where a step is rejected. See
  /// docs/solvers.md for the measurements behind the defaults.
  double initial_lambda = 0;
  /// Damping below this is switched off (the step is a Gauss-Newton step); a rejected
  /// undamped step restarts the damping here. Some public datasets have directions H barely
  /// constrains (ais2klinik): damping of even 1e-9 of diag(H) shortens the steps along them
  /// tenfold and turns 7 iterations into 30.
  double min_lambda = 1e-9;
  /// How many times an undamped step that raises chi2 is halved and tried again before
  /// damping starts. One halving takes parking-garage from its chordal start in 5 iterations
  /// instead of 14; more halvings cost MIT from its file start 9 iterations.
  int max_step_halvings = 1;
  /// Give up (converged: no step lowers chi2) when lambda exceeds this.
  double max_lambda = 1e16;

  bool IsValid(std::string* why) const;
};

/// Powell's dog-leg (options.dogleg): a trust region of radius r around the current values
/// in tangent coordinates; the step is the Gauss-Newton step where it fits, else the
/// steepest-descent (Cauchy) step cut at r, else the point at distance r on the path between
/// the two. After each step the gain ratio rho (actual over predicted decrease of chi2)
/// moves the radius.
struct DogLegOptions {
  /// The first radius. 0: the length of the first Gauss-Newton step (so the first step is a
  /// Gauss-Newton step, as in lm with initial_lambda 0).
  double initial_radius = 0;
  /// Give up (converged: no step lowers chi2) when the radius falls below this.
  double min_radius = 1e-12;
  /// The radius never grows beyond this.
  double max_radius = 1e12;
  /// rho above this (a good model): the radius grows to at least grow_factor times the step.
  double grow_above = 0.75;
  /// rho below this (a poor model, or a rejected step): the radius shrinks to the step's
  /// length times shrink_factor.
  double shrink_below = 0.25;
  double grow_factor = 3.0;
  double shrink_factor = 0.25;

  bool IsValid(std::string* why) const;
};

struct SolverOptions {
  /// The step strategy: Algorithm::kLevenbergMarquardt ("lm"), kGaussNewton ("gn"), kDogLeg
  /// ("dogleg") or kCeres ("ceres").
  Algorithm algorithm = Algorithm::kLevenbergMarquardt;
  /// The linear solver, by name: "auto", "block", "cholmod", "ldlt", "qr" or one a plugin
  /// registered.
  LinearSolverType linear_solver = LinearSolverType::kAuto;

  // Stopping rules, common to every step strategy.
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

  // The pieces' own settings.
  LevenbergMarquardtOptions lm;
  DogLegOptions dogleg;
  /// The linear solvers' settings (tether/core/linear_solver.h), among them the reuse of an
  /// earlier factorisation by cholmod and ldlt (linear.max_reuse_iterations).
  LinearSolverOptions linear;

  /// Threads that evaluate the factors and assemble H and g (gn, lm and dogleg; 1 to 256).
  /// The results are bit-identical for any number. Default 1: the factorisation, not the
  /// assembly, dominates a solve (CHOLMOD's BLAS has threads of its own), and tether is
  /// often run several times at once (tests, benchmarks, a batch); docs/solvers.md has the
  /// measurements.
  int num_threads = 1;
  /// Called after every iteration (and once for iteration 0).
  std::function<void(const IterationSummary&)> callback;
  /// Where set, called after `callback` with the same summary; returning false ends the solve
  /// there with status kStopped and the values of that iteration (an accepted step is kept, a
  /// rejected one is not). gn, lm, dogleg and ceres.
  std::function<bool(const IterationSummary&)> keep_going;

  /// Checks the common settings and every piece's (lm, dogleg, linear), and that the step
  /// strategy and linear solver are registered.
  bool IsValid(std::string* why) const;
};

struct SolverSummary {
  SolverStatus status = SolverStatus::kInvalidInput;
  std::string message;  ///< why it stopped, in words
  Algorithm algorithm = Algorithm::kLevenbergMarquardt;
  LinearSolverType linear_solver = LinearSolverType::kAuto;
  /// chi2 (sum of |R e|^2 over the factors, their robust losses left out) at the start and
  /// at the end.
  double initial_chi2 = 0;
  double final_chi2 = 0;
  /// The objective the solver minimised: each factor's rho(chi2) where it carries a robust
  /// loss, its chi2 otherwise (FactorGraph::Cost). Equal to the chi2 where no factor carries
  /// a loss; the iteration log's chi2 column is this cost.
  double initial_cost = 0;
  double final_cost = 0;
  int iterations = 0;  ///< iterations tried (accepted or not)
  int accepted_iterations = 0;
  int factorizations = 0;  ///< numeric factorisations (iterations less those that reused one)
  /// Iterations of an iterative linear solver (a plugin's, e.g. pcg), over the whole solve.
  int linear_solver_iterations = 0;
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
  /// The settings of the pieces in use, one line each (label, text), for FullReport.
  std::vector<std::pair<std::string, std::string>> settings;
  std::vector<IterationSummary> log;

  bool IsSolutionUsable() const {
    return status == SolverStatus::kConverged || status == SolverStatus::kMaxIterations ||
           status == SolverStatus::kTimeLimit || status == SolverStatus::kStopped;
  }
  /// One line: status, chi2 before and after, iterations, time; where the result is not usable,
  /// the message saying why after a colon.
  std::string BriefReport() const;
  /// Several lines: problem size, settings, timings and why it stopped.
  std::string FullReport() const;
};

/// The BriefReport line: std::cout << summary.
std::ostream& operator<<(std::ostream& os, const SolverSummary& s);

}  // namespace tether
