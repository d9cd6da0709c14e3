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
// How (docs/smoother.md): the smoother keeps a block Cholesky factor of the Gauss-Newton
// system between updates, linearised at a point theta, with the step delta solved from it;
// the estimate is theta (+) delta. An update adds and removes the factors' rows, refactors
// only the columns it affects (the touched variables and their ancestors in the elimination
// tree, reordered by constrained minimum degree with the newest variables last), redoes the
// forward solution of those columns and the back substitution where the step changes, and
// moves the linearisation point of the variables whose step is too large (beyond
// relinearize_threshold, or relinearize_sigmas standard deviations of their own information),
// re-linearising their factors; within the update again where a step is far too large
// (iterate_ratio; the steps near the thresholds, iterate_fraction, go then too), else at the
// start of the next. Every estimate is then within a small fraction of the optimum of the
// graph so far (5.8e-4 relative chi2 at most on the public files, checked after every
// update); Finish() solves in batch to convergence.
//
// Guarantees:
// - An update that is invalid (a new value whose key exists, a factor referring to a key that
//   has no value or a value of another type, an unknown or repeated handle) throws
//   InvalidArgument before anything changes: graph, estimate and handles stay as they were.
//   So does a new factor whose evaluation throws at the values it starts from (each new
//   factor is evaluated once, with its Jacobians, before any change): that exception
//   propagates and nothing changes. A factor that throws later, at values the solve reaches,
//   leaves the update's changes in and throws.
// - Variables no factor uses are held where they are (a new pose whose edges come later);
//   a variable whose last factor an update removes is erased from the estimate.
// - The gauge is chosen as Optimize chooses it (the graph's fixed set, else the lowest-key
//   pose some factor uses where no prior anchors the graph).
// - Deterministic: the same sequence of updates gives bit-identical estimates for a given
//   number of threads.
// - After Finish() the estimate is the batch optimum of the graph (Optimize to convergence
//   from the current estimate).
// - A factorisation that fails (a variable its factors do not determine, a value that is not
//   finite) falls back to a batch solve (options.update) for that update; the summary says so.
#include <Eigen/Core>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "tether/core/enum_names.h"
#include "tether/core/factor_graph.h"
#include "tether/core/values.h"
#include "tether/solvers/covariance.h"
#include "tether/solvers/solver_options.h"

namespace tether {

/// How the smoother refactors the columns an update changes (docs/smoother.md, step 4).
enum class SmootherFactorization {
  kAuto,          ///< multifrontal where the variables are mostly 6 wide (3D), else left-looking
  kLeftLooking,   ///< column by column, subtracting every earlier column that reaches one
  kMultifrontal,  ///< supernodes as dense fronts; unchanged subtrees keep their update matrices
};
inline constexpr EnumName<SmootherFactorization> kSmootherFactorizationNames[] = {
    {SmootherFactorization::kAuto, "auto"},
    {SmootherFactorization::kLeftLooking, "left-looking"},
    {SmootherFactorization::kMultifrontal, "multifrontal"}};
constexpr const auto& EnumNames(SmootherFactorization) { return kSmootherFactorizationNames; }

/// How an update solves (docs/smoother.md, "Local mode").
enum class SmootherMode {
  /// Keeps a Cholesky factor of the whole system between updates and refactors the columns
  /// an update affects (the default; the sections above).
  kFactor,
  /// Solves each update's change over a region around the variables it touched, grown until
  /// no variable at the region's edge could lower chi2 by more than local_tolerance (a share
  /// of chi2 per variable) if it moved alone; a batch solve of the whole graph now and then
  /// (the local_batch_* rules) and where a region grows beyond local_max_region. For large
  /// graphs, where the corrections of an update are local but the factor's path to the root
  /// is long (a 100k-pose Manhattan world).
  kLocal,
};
inline constexpr EnumName<SmootherMode> kSmootherModeNames[] = {{SmootherMode::kFactor, "factor"},
                                                                {SmootherMode::kLocal, "local"}};
constexpr const auto& EnumNames(SmootherMode) { return kSmootherModeNames; }

struct SmootherOptions {
  SmootherOptions();

  /// kFactor (default) or kLocal. The options below up to `factorization` are kFactor's; the
  /// local_* ones are kLocal's; the rest apply to both.
  SmootherMode mode = SmootherMode::kFactor;

  /// A variable whose step (its tangent delta from the linearisation point) is too large is
  /// re-linearised: its linearisation point moves to the estimate and its factors are
  /// evaluated there. Too large: beyond relinearize_threshold (infinity norm, the tangent's
  /// units), or beyond relinearize_sigmas standard deviations of the information the
  /// variable's own factors give it (sqrt of H's diagonal: catches precise measurements, a
  /// rotation known to a few milliradians, where a fixed threshold is too coarse). Smaller:
  /// estimates closer to the optimum so far, more columns refactored per update; 0: any step
  /// at all (every variable whose step changed is re-linearised). Defaults 0.02 and 1
  /// (benchmarks/RESULTS.md, "The incremental smoother, version 2").
  double relinearize_threshold = 0.02;
  double relinearize_sigmas = 1;
  /// An update solves again (re-linearising first) while some variable's step is more than
  /// this many times too large, at most rounds_per_update times: a step that large means the
  /// linearisation was far off. Smaller steps that are too large are re-linearised at the start
  /// of the next update. Default 5.
  double iterate_ratio = 5;
  /// When an update solves again, the variables whose step is beyond this fraction of the
  /// thresholds (but not beyond them) are re-linearised too: after a loop closure, the many
  /// steps just below the thresholds are what leaves the estimate short of the optimum of the
  /// graph so far. 1: only steps beyond the thresholds. Default 0.5 (benchmarks/RESULTS.md,
  /// "At every step").
  double iterate_fraction = 0.5;
  /// An update also solves again (as for iterate_ratio) while more than this share of the
  /// variables have steps too large: a large part of the map moved, as at a loop closure in
  /// a small graph. 1: never for this reason. Default 0.2 (benchmarks/RESULTS.md, "New
  /// variables start at their own optimum").
  double iterate_share = 0.2;
  /// Each new variable starts where its new factors, with every other variable held at its
  /// value, cost least (a few Gauss-Newton steps on that variable alone), not at the value
  /// given for it, where it has at least two such factors that determine it and it is not
  /// held (fixed, or the pose the automatic gauge holds). A new pose
  /// guessed from odometry thus starts near where its loop closure puts it: the first solve
  /// then moves the map by the closure's correction, not by the guess's error, and fewer
  /// updates need a second round (sphere2500: 1048 of 2500 instead of 2035, replay 37 s ->
  /// 25 s; benchmarks/RESULTS.md, same section). Default true.
  bool refine_new_values = true;
  /// At most this many factorise-solve rounds per update. Default 8.
  int rounds_per_update = 8;
  /// The back substitution goes down the elimination tree below a variable only where the
  /// variable's step changed by more than this (infinity norm). 0: wherever it changed at all
  /// (the exact solution of the linear system). Default 1e-9.
  double wildfire_threshold = 1e-9;
  /// Default kAuto (chosen at every full refactor; benchmarks/RESULTS.md, "Multifrontal").
  SmootherFactorization factorization = SmootherFactorization::kAuto;
  /// kLocal: a variable at the edge of the region is taken into it (with its neighbours) while
  /// moving it alone, everything else held, would lower chi2 (g^T H^-1 g over its factors) by
  /// more than this share of chi2 per variable (chi2 and the number of variables at the last
  /// batch solve; at least 1e-6 per variable): a relative bar, as the 1e-3 is. Smaller:
  /// larger regions, estimates closer to the optimum. Default 4e-4 (1e-3 to 1.5e-3 chi2 in the
  /// simulated Manhattan worlds, 2.3 to 3.7 chi2 a variable).
  double local_tolerance = 4e-4;
  /// kLocal: the region starts with the update's variables and their neighbours this many
  /// factors away. Default 2.
  int local_hops = 2;
  /// kLocal: a region that grows beyond this many variables stops growing and the update is
  /// solved in batch instead (the change is not local: a long loop closed). Default 2000.
  int local_max_region = 2000;
  /// kLocal: a batch solve of the whole graph (options.update) collects the small errors the
  /// regions leave at their edges. It comes once what the edges left since the last one (the
  /// edge variables' gains, summed over the updates) exceeds local_batch_gap times chi2 at the
  /// last one, and at the latest once the updates since the last one reach local_batch_share
  /// of the variables. Defaults 2e-4 and 0.05 (benchmarks/RESULTS.md, "Local mode").
  double local_batch_gap = 2e-4;
  double local_batch_share = 0.05;
  /// kLocal: an update whose local solve lowers chi2 by more than this share of chi2 (at the
  /// last batch solve) is solved in batch as well. A gain that large means the estimate was
  /// far from the optimum there: a long loop closed, or what earlier regions left at their
  /// edges added up (the single edge variables' gains do not show a correction that bends a
  /// long stretch of the graph). Chi2 counts as at least 1e-6 a variable in these shares (it
  /// is 0 while the graph has no loop). Default 3e-3 (benchmarks/RESULTS.md, "Local mode").
  double local_batch_correction = 3e-3;
  /// Evaluate chi2 of the whole graph before and after every update (SmootherUpdate's
  /// chi2_before and chi2_after): a pass over every factor, so off by default.
  bool compute_chi2 = false;
  /// kLocal: the batch solves of the whole graph. Default: Gauss-Newton over CHOLMOD, at most
  /// 10 iterations (from an estimate this near the optimum it converges in 2-4; Levenberg-
  /// Marquardt's damping can crawl there); `update` takes over where it fails.
  SolverOptions local_batch;
  /// The batch solve an update falls back to where the incremental factorisation fails.
  /// Defaults: Levenberg-Marquardt over CHOLMOD, at most 10 iterations, the other settings
  /// Optimize's defaults.
  SolverOptions update;
  /// Finish(): a solve to convergence. Defaults: Levenberg-Marquardt over CHOLMOD, at most 100
  /// iterations, function_tolerance 1e-12 (so that the result is the batch optimum to the
  /// last digits, not merely close to it). In kLocal, Gauss-Newton with these stopping rules
  /// runs first.
  SolverOptions finish;
  /// Marginal(key): the method of tether::Marginals (default CHOLMOD, sparse inverse subset).
  CovarianceOptions covariance;
  /// Marginal(key) of a variable near the root of the kept factor's elimination tree (a path
  /// of at most 32 columns to it, as the newest poses have) comes from that factor: no
  /// linearisation, no factorisation. It is then the covariance at the linearisation point,
  /// which is within the re-linearisation thresholds of the estimate. false: always
  /// tether::Marginals at the estimate. Default true (benchmarks/RESULTS.md, "The newest pose's
  /// marginal from the kept factor").
  bool marginal_from_factor = true;

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
  /// FixedLagSmoother: variables marginalised at the end of this update (older than the lag).
  int marginalized = 0;
  /// The handles of the new factors, in the order of the update's graph. Pass them in a later
  /// update's factors_to_remove to take the factors out.
  std::vector<FactorId> new_factor_ids;
  /// False where there was nothing to solve (no factor in the graph).
  bool solved = false;
  /// Every column was refactored (the first update, a changed gauge or fixed set, after
  /// Finish() or a failure).
  bool structure_rebuilt = false;
  /// The incremental factorisation failed and the update was solved in batch (options.update).
  bool fell_back = false;
  SolverStatus status = SolverStatus::kConverged;  ///< of the solve
  std::string message;                             ///< what happened, where it is not plain
  int iterations = 0;                              ///< factorise-solve rounds
  int affected_columns = 0;                        ///< columns refactored, summed over the rounds
  int back_substituted = 0;                        ///< columns whose step was recomputed, summed over the rounds
  int relinearized = 0;                            ///< variables whose linearisation point moved
  /// kLocal: the variables of the region solved (0 where the update was solved in batch), and
  /// whether the whole graph was solved in batch (options.update) in this update.
  int region = 0;
  bool batch = false;
  /// Of the whole graph at the previous estimate plus the new values, and at the new estimate;
  /// NaN unless options.compute_chi2.
  double chi2_before = 0;
  double chi2_after = 0;
  double seconds = 0;  ///< the whole update: checks, changes and solve
  /// Evaluating factors; ordering and refactoring the affected columns (with their forward
  /// solution); the back substitution.
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

  /// Starts over with `graph` at `values`, taken as given (not refined: they are an estimate
  /// already), as a new smoother's first update: every earlier factor, variable and handle
  /// goes, and the new graph's handles are the ones returned. What the fixed-lag smoother does
  /// after marginalising. Throws as Update does, changing nothing.
  SmootherUpdate Restart(FactorGraph graph, Values values);

  /// The current estimate of every variable.
  const Values& Estimate() const { return estimate_; }
  /// The marginal covariance of `key`. Where options.marginal_from_factor and the key is near
  /// the root of the kept factor's elimination tree (the newest pose, usually), from that
  /// factor: the covariance at the linearisation point. Otherwise at the current estimate, by
  /// tether::Marginals over the current graph (the factorisation is kept until the next Update
  /// or Finish). Throws as Marginals does: InvalidArgument for an unknown, fixed or unused key,
  /// RankDeficientError for a singular system.
  Eigen::MatrixXd Marginal(Key key) const;
  /// Solves to convergence from the current estimate (options.finish) and returns the
  /// estimate, then the batch optimum of the graph. The summary is finish_summary().
  const Values& Finish();
  const SolverSummary& finish_summary() const { return finish_summary_; }

  /// The factors so far, with the handles Update returned.
  const FactorGraph& graph() const { return graph_; }
  const SmootherOptions& options() const { return options_; }

 private:
  struct State;
  // Sorts and dedupes *keys, then erases those no factor uses any more (they would be held
  // forever): out of the estimate, the fixed set and the factor. Returns how many it erased.
  int EraseUnused(std::vector<Key>* keys);
  // Update's changes and solve in SmootherMode::kLocal (after Update's checks).
  void UpdateLocal(FactorGraph new_factors, Values new_values, const std::vector<FactorId>& factors_to_remove,
                   SmootherUpdate* u);
  SmootherOptions options_;
  bool refine_ = true;  // false in Restart's first update: the values are an estimate already
  FactorGraph graph_;
  Values estimate_;
  SolverSummary finish_summary_;
  std::unique_ptr<State> state_;                  // the factor, linearisation point, bookkeeping
  mutable std::unique_ptr<Marginals> marginals_;  // of the current graph and estimate
};

}  // namespace tether
