#pragma once
// Internal: the linear system of one iteration, (H + lambda D) delta = -g with
// D = clamp(diag(H)), over the linear solver chosen by name (tether/core/linear_solver.h).
// It assembles H (or J, for solvers that work on the Jacobian) after each linearisation,
// applies the damping a step strategy asks for, and solves; where the solver is direct it
// first tries the factorisation of an earlier H as a preconditioner of conjugate gradients
// (Pcg below), which near the optimum replaces most factorisations.
#include <memory>
#include <string>
#include <vector>

#include "problem.h"
#include "tether/core/linear_solver.h"
#include "tether/solvers/solver_options.h"
#include "tether/solvers/step_strategy.h"

namespace tether {
namespace internal {

/// Time and counts of the linear solves of one solve, for the summary.
struct LinearSolveStats {
  double factorize_seconds = 0;
  double solve_seconds = 0;  ///< solving, less the factorisations
  double last_factorize_seconds = 0;
  int factorizations = 0;
  int iterative_iterations = 0;  ///< an iterative solver's iterations (LinearSolver::last_iterations)
};

/// The reuse rule: where the operation counts of a factorisation (f), a solve (s) and a product
/// with H (m) are known, caps *max_iterations at the iterations after which reusing an earlier
/// factorisation would no longer be cheaper than factorising afresh, and turns *reuse off
/// where even none would be (linear_system.cc). Unknown counts (0) leave both as they are.
void ReuseWhileCheaper(double f, double s, double m, bool* reuse, int* max_iterations);

class LinearSystem : public StepSystem {
 public:
  /// Builds the structure and lets the solver analyse it. Throws tether::Error where the
  /// solver cannot handle the problem. `solver`: one already made from `entry` (null: made
  /// here); `split`: it partitioned the problem (LinearSolver::Partition) and `p` holds this
  /// process's share of the factors, so H and g here are this process's share.
  /// `damped`: where split, which columns this process's share damps (those of the variables
  /// it owns).
  LinearSystem(Problem* p, const LinearSolverEntry& entry, const LinearSolverOptions& options,
               std::unique_ptr<LinearSolver> solver = nullptr, bool split = false, std::vector<char> damped = {});

  /// After Problem::Linearize: builds H (or J) and the gradient for the current point.
  void Assemble();
  /// How many times Assemble ran: a strategy that keeps work per linearisation compares it.
  int assemblies() const override { return assemblies_; }

  /// delta solving (H + lambda D) delta = -g. Where a factorisation of an earlier H exists,
  /// the system is first solved by conjugate gradients preconditioned with it (at most
  /// max_reuse_iterations); only if that does not converge is H factorised afresh.
  /// it->reused_factorization and it->cg_iterations say which happened.
  LinearSolverStatus Solve(double lambda, std::vector<double>* delta, IterationSummary* it) override;

  /// The linear model's decrease of chi2 along d, -2 g.d - d^T H d (H undamped; dDd =
  /// d^T D d), for d solved at `lambda`. For a step solved exactly, (H + lambda D) d = -g turns
  /// it into -g.d + lambda d^T D d; a step from conjugate gradients or an iterative solver is
  /// exact only to their tolerance, so H d is formed.
  double PredictedDecrease(const std::vector<double>& d, double lambda, double dDd, bool reused) override;
  /// d^T D d.
  double ScaledSquaredNorm(const std::vector<double>& d) const override;
  /// y = H x with H undamped (the matrix of the last Assemble).
  void MultiplyUndamped(const std::vector<double>& x, std::vector<double>* y) override;

  const std::vector<double>& gradient() const override { return g_; }
  /// Where the solver spans processes: makes n values one across them (the first process's).
  void Agree(double* values, int n) const {
    if (group_ != nullptr) group_->Broadcast(values, n);
  }
  const LinearSolveStats& stats() const { return stats_; }
  std::string Description() const { return solver_->Description(); }

 private:
  double ClampedDiag(std::size_t i) const;
  void ApplyDamping(double lambda);
  // y = H x with H symmetric given by its upper triangle (mat_, damping included). mat_
  // holds the diagonal blocks whole; their entries below the diagonal are skipped, as CHOLMOD
  // skips them.
  void MultiplyH(const std::vector<double>& x, std::vector<double>* y) const;
  // H x where H is split between processes: the sum of every process's share (MultiplyH alone
  // otherwise).
  void MultiplyWholeH(const std::vector<double>& x, std::vector<double>* y) const;
  // Where the factors are split: the sum over the processes, made one; else as Agree.
  void Total(double* values, int n) const;
  // y = J^T J x over the Jacobian's rows (the damping rows left out).
  void MultiplyJtJ(const std::vector<double>& x, std::vector<double>* y);
  bool Pcg(std::vector<double>* delta, int* iterations);

  Problem* p_;
  LinearSystemForm form_;
  bool exact_;  // the solver's Solve is exact (a direct factorisation)
  Csc mat_;
  std::vector<int> damping_pos_;
  std::vector<double> g_, neg_g_, diag_, undamped_diag_, rhs_;
  double lambda_ = 0;             // the damping in mat_
  bool reuse_ = false;            // whether to try the earlier factorisation first (ReuseWhileCheaper)
  int max_reuse_iterations_ = 0;  // and for at most this many iterations
  int assemblies_ = 0;
  bool have_factor_ = false;                // solver_ holds the factorisation of an earlier H
  std::vector<double> r_, z_, p_dir_, hp_;  // conjugate-gradient work (no allocation per step)
  std::vector<double> jx_;                  // J x, for MultiplyJtJ
  std::unique_ptr<LinearSolver> solver_;
  ProcessGroup* group_ = nullptr;  // solver_->processes()
  bool split_ = false;             // H, g and the diagonal here are this process's share
  std::vector<char> damped_;       // split: the columns whose damping is in this process's share
  LinearSolveStats stats_;
};

}  // namespace internal
}  // namespace tether
