#pragma once
// FixedLagSmoother: the incremental smoother over a window of the most recent variables, for
// runs of any length. Variables older than the lag are marginalised: the factors that use them
// are linearised at the current estimate and their information is moved, by the Schur
// complement, into one MarginalPrior on the variables they shared factors with (the
// separator), whose linearisation point stays where the marginalisation was done. Memory and
// step time therefore stay flat however long the run.
//
//   FixedLagOptions o;
//   o.lag = 200;                                   // poses, with one update per pose
//   FixedLagSmoother smoother(o);
//   smoother.Update(std::move(factors), std::move(values));
//   const SE2d x = smoother.Estimate().At<SE2d>(X(n));
//   Values done = smoother.TakeMarginalized();     // final estimates of what left the window
//
// How (docs/smoother.md, "Fixed lag"): every Update goes to an IncrementalSmoother holding the
// window (options.smoother: its engine, thresholds and defaults). Each variable is stamped
// with the time of the update that added it (Update's `time`, by default the number of updates
// before it, so that with one pose per update the lag counts poses). Marginalising costs one
// factorisation of the window, so it happens in batches: once the oldest variable is more than
// lag * (1 + batch) old, every variable more than lag old goes at once, and the window's
// smoother restarts from the window's factors, the new prior and the current estimate.
//
// Exactness: while every factor stays inside the window, the estimate is the incremental
// smoother's on the whole graph up to the linearisation of the marginalised factors, which is
// frozen where they left (the window's estimates equal the full smoother's to about 1e-6 on a
// simulated world whose loop closures all fall inside the window; tests/solvers). A factor that
// would reach a marginalised variable cannot be added (InvalidArgument says which variable):
// a loop closure to a place older than the lag needs a longer lag, or the full smoother.
//
// Held variables: the graph's fixed set and the automatic gauge (the lowest pose where nothing
// anchors the graph) are held as in IncrementalSmoother. A held variable that is marginalised
// is conditioned on (its step is zero). Where the graph measures only relative quantities (the
// automatic gauge), the gauge moves on with the window when its pose leaves: the lowest pose of
// the separator is held at its estimate and the marginalisation is conditioned on it too, so
// the window's estimates are relative to it, as the full smoother's are relative to the first
// pose. (A prior that kept the window's place in the world would know it only as well as the
// whole past determines it, which after many poses drowns in the rounding of its relative
// information.) Where something anchors the graph (a prior, a fixed variable), the marginal
// prior carries that anchor (MarginalPrior::anchors) and no pose is held for the gauge.
#include <Eigen/Core>
#include <deque>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/values.h"
#include "tether/solvers/incremental_smoother.h"

namespace tether {

struct FixedLagOptions {
  /// Variables added more than this long before the latest update are marginalised, in the
  /// units of Update's `time` (by default updates, so poses where each update adds one).
  /// Default 100.
  double lag = 100;
  /// Marginalise in batches: once the oldest variable is older than lag * (1 + batch), every
  /// variable older than lag goes. 0: every update where one is older than lag (one
  /// factorisation of the window each time). Default 0.25.
  double batch = 0.25;
  /// The smoother of the window (its engine, thresholds and solves).
  SmootherOptions smoother;
  /// Before marginalising, the window is solved to its optimum with these options, and the
  /// leaving factors are linearised there: the prior keeps that linearisation for good, so a
  /// point short of the optimum (the smoother's estimate is within its re-linearisation
  /// thresholds of it) would stay in the prior as an error. Default: Gauss-Newton, at most 10
  /// iterations. Where it fails, the marginalisation is done at the smoother's estimate.
  SolverOptions converge;

  FixedLagOptions();

  /// True when every part can be used; otherwise says why (when `why` is not null).
  bool IsValid(std::string* why) const;
};

class FixedLagSmoother {
 public:
  /// Throws InvalidArgument (with IsValid's reason) for invalid options.
  explicit FixedLagSmoother(const FixedLagOptions& options = {});
  ~FixedLagSmoother();
  FixedLagSmoother(const FixedLagSmoother&) = delete;
  FixedLagSmoother& operator=(const FixedLagSmoother&) = delete;

  /// As IncrementalSmoother::Update, at `time` (NaN: the number of earlier updates; times
  /// must not decrease), then marginalises what has grown older than the lag (the summary's
  /// `marginalized` and `seconds` include that). Throws InvalidArgument, changing nothing, for
  /// an invalid update, a factor that refers to a marginalised variable or a time that runs
  /// backwards. A marginalisation that cannot be computed (a factor that cannot be evaluated
  /// at the estimate) is put off to the next update; the summary's message says so.
  SmootherUpdate Update(FactorGraph new_factors = {}, Values new_values = {},
                        std::vector<FactorId> factors_to_remove = {},
                        double time = std::numeric_limits<double>::quiet_NaN());

  /// The estimate of the variables in the window.
  const Values& Estimate() const { return window_->Estimate(); }
  /// The marginal covariance of a variable in the window (the marginal prior included).
  Eigen::MatrixXd Marginal(Key key) const { return window_->Marginal(key); }
  /// Solves the window to convergence (its factors and the marginal prior) and returns it.
  const Values& Finish() { return window_->Finish(); }
  /// The final estimates of the variables marginalised since the last call, moved out.
  Values TakeMarginalized();
  /// True for a key that was marginalised (it is no longer in the window).
  bool WasMarginalized(Key key) const;
  /// Variables marginalised so far.
  std::size_t marginalized() const { return marginalized_count_; }
  /// The window's factors and the marginal prior (their handles are the window smoother's,
  /// not the ones Update returns).
  const FactorGraph& graph() const { return window_->graph(); }
  const FixedLagOptions& options() const { return options_; }

 private:
  // Marginalises `keys` (window variables); false (and *why) where it cannot be computed.
  bool Marginalize(const std::vector<Key>& keys, std::string* why);
  void RememberMarginalized(Key k);

  FixedLagOptions options_;
  std::unique_ptr<IncrementalSmoother> window_;
  std::unordered_map<FactorId, FactorId> inner_of_;  // handle given out -> the window's handle
  std::unordered_map<FactorId, FactorId> outer_of_;  // and back
  FactorId next_id_ = 0;
  std::deque<std::pair<double, Key>> added_;  // (time, key) of the window's variables, oldest first
  double last_time_ = -std::numeric_limits<double>::infinity();
  std::size_t updates_ = 0;
  std::map<Key, Key> marginalized_ranges_;  // first -> last of each run of marginalised keys
  std::size_t marginalized_count_ = 0;
  Key moving_gauge_ = 0;  // the pose this smoother holds for the gauge, where it moved it on
  bool has_moving_gauge_ = false;
  Values taken_out_;
};

}  // namespace tether
