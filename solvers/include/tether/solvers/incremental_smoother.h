#pragma once
// IncrementalSmoother: the one place where front-ends feed the back-end. They add a few
// factors and variables at a time (and take factors out again by their handles), and read a
// fresh estimate and marginal covariances after each step.
//
//   IncrementalSmoother smoother;
//   FactorGraph f;  Values v;
//   v.Insert(X(1), SE2d(1, 0, 0));
//   f.Add<BetweenSE2>(X(0), X(1), odometry, noise);
//   SmootherUpdate u = smoother.Update(std::move(f), std::move(v));
//   const SE2d x1 = smoother.Estimate().At<SE2d>(X(1));
//   smoother.Update({}, {}, {u.new_factor_ids[0]});        // take the edge out again
//   const Values& optimum = smoother.Finish();             // the batch optimum
//
// Version 1 (this one) re-solves the whole graph on every update that needs a solve:
// Levenberg-Marquardt (Optimize, options.update), warm-started from the previous estimate plus
// the new values, for a few iterations. The structure of the linear system, the ordering and
// the factorisation are rebuilt by every solve; keeping them between updates and redoing only
// what an update touches is the next step (docs/smoother.md). Each solve is exactly Optimize
// on the graph so far from the previous estimate. The one thing v1 reuses: an update whose new
// factors all have zero error at the previous estimate plus the new values (a new pose
// composed from its odometry edge) keeps the estimate without solving (skip_solve_chi2).
//
// Guarantees:
// - An update that is invalid (a new value whose key exists, a factor referring to a key that
//   has no value or a value of another type, an unknown or repeated handle) throws
//   InvalidArgument before anything changes: graph, estimate and handles stay as they were.
// - Variables no factor uses are held where they are (a new pose whose edges come later);
//   a variable whose last factor an update removes is erased from the estimate.
// - The gauge is chosen as Optimize chooses it (the graph's fixed set, else the lowest-key
//   pose some factor uses where no prior anchors the graph).
// - Deterministic: the same sequence of updates gives bit-identical estimates for a given
//   number of threads.
// - After Finish() the estimate is the batch optimum of the graph (Optimize to convergence
//   from the current estimate).
#include <Eigen/Core>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/values.h"
#include "tether/solvers/covariance.h"
#include "tether/solvers/solver_options.h"

namespace tether {

struct SmootherOptions {
  SmootherOptions();

  /// The solve after each update, from the previous estimate plus the new values. Defaults:
  /// Levenberg-Marquardt over CHOLMOD, at most 10 iterations, function_tolerance 1e-6 (not
  /// Optimize's 1e-8: 15-20% less time on the intel and M3500 replays,
  /// and every estimate checked stayed within 6e-10 relative chi2 of the optimum so far;
  /// benchmarks/RESULTS.md), the other settings Optimize's defaults.
  SolverOptions update;
  /// Finish(): a solve to convergence. Defaults: Levenberg-Marquardt over CHOLMOD, at most 100
  /// iterations, function_tolerance 1e-12 (so that the result is the batch optimum to the
  /// last digits, not merely close to it).
  SolverOptions finish;
  /// An update that removes nothing, after a solve that converged, whose new factors have
  /// together at most this chi2 at the previous estimate plus the new values (a new pose
  /// placed where its odometry edge puts it) keeps the estimate without solving: factors with
  /// zero error add nothing to the gradient, so the previous stationary point is one of the
  /// new graph too. Default 1e-12; negative: solve after every update.
  double skip_solve_chi2 = 1e-12;
  /// Marginal(key): the method of tether::Marginals (default CHOLMOD, sparse inverse subset).
  CovarianceOptions covariance;

  /// True when every part can be used; otherwise says why (when `why` is not null).
  bool IsValid(std::string* why) const;
};

/// What one Update did.
struct SmootherUpdate {
  int factors_added = 0;
  int factors_removed = 0;
  int variables_added = 0;
  /// Variables erased because the update removed their last factor.
  int variables_removed = 0;
  /// The handles of the new factors, in the order of the update's graph. Pass them in a later
  /// update's factors_to_remove to take the factors out.
  std::vector<FactorId> new_factor_ids;
  /// False where there was nothing to solve (no factor in the graph) or the solve was skipped.
  bool solved = false;
  /// The solve was skipped: the new factors have zero error at the estimate (skip_solve_chi2).
  bool skipped = false;
  /// Whether the linear system's structure (ordering, symbolic factorisation) was built anew.
  /// Version 1 rebuilds it on every solve.
  bool structure_rebuilt = false;
  SolverStatus status = SolverStatus::kConverged;  ///< of the solve
  std::string message;                             ///< the solver's reason to stop
  int iterations = 0;
  double chi2_before = 0;  ///< of the whole graph at the previous estimate plus the new values
  double chi2_after = 0;   ///< at the new estimate
  double seconds = 0;      ///< the whole update: checks, changes and solve
  /// The solve's split (SolverSummary): building the structure (ordering, symbolic analysis),
  /// evaluating and assembling, numeric factorisations, solving for the steps.
  double setup_seconds = 0;
  double linearize_seconds = 0;
  double factorize_seconds = 0;
  double solve_seconds = 0;
};

class IncrementalSmoother {
 public:
  /// Throws InvalidArgument (with IsValid's reason) for invalid options.
  explicit IncrementalSmoother(const SmootherOptions& options = {});
  ~IncrementalSmoother();
  IncrementalSmoother(const IncrementalSmoother&) = delete;
  IncrementalSmoother& operator=(const IncrementalSmoother&) = delete;

  /// Adds `new_values` and the factors of `new_factors` (and the variables it fixes), removes
  /// the factors with the handles `factors_to_remove`, then solves. Throws InvalidArgument,
  /// changing nothing, for an invalid update (see the guarantees above). A solve that fails
  /// numerically (a singular system, non-finite chi2) keeps the update's changes and the last
  /// good values; the summary's status says what happened.
  SmootherUpdate Update(FactorGraph new_factors = {}, Values new_values = {},
                        std::vector<FactorId> factors_to_remove = {});

  /// The current estimate of every variable.
  const Values& Estimate() const { return estimate_; }
  /// The marginal covariance of `key` at the current estimate, by tether::Marginals over the
  /// current graph (the factorisation is kept until the next Update or Finish). Throws as
  /// Marginals does: InvalidArgument for an unknown, fixed or unused key, RankDeficientError
  /// for a singular system.
  Eigen::MatrixXd Marginal(Key key) const;
  /// Solves to convergence from the current estimate (options.finish) and returns the
  /// estimate, then the batch optimum of the graph. The summary is finish_summary().
  const Values& Finish();
  const SolverSummary& finish_summary() const { return finish_summary_; }

  /// The factors so far, with the handles Update returned.
  const FactorGraph& graph() const { return graph_; }
  const SmootherOptions& options() const { return options_; }

 private:
  SmootherOptions options_;
  FactorGraph graph_;
  Values estimate_;
  SolverSummary finish_summary_;
  std::unordered_map<Key, int> uses_;  // factors of graph_ per variable
  double chi2_ = 0;                    // of graph_ at estimate_
  bool converged_ = true;              // estimate_ is a stationary point of graph_ (to the solve's tolerances)
  mutable std::unique_ptr<Marginals> marginals_;  // of the current graph and estimate
};

}  // namespace tether
