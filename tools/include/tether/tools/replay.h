#pragma once
// `tether replay`: feeds a graph file into the incremental smoother pose by pose, as a
// front-end would, and times each update.
//
// Poses are added in increasing id order. At step i the variable with the i-th smallest id
// is added, with the initial guess of the current estimate of the variable before it composed
// with the edge between the two (through the factor's Predict; failing that, any edge to a
// variable added before, and failing that the file's value), together with every factor whose
// variables have all been added by then. The smoother is updated every `every`-th step (and
// after the last). After the last step Finish() solves to convergence, and the result is
// compared with the batch optimum of the whole file (Optimize from the chordal start).
//
// ReplayFile is the replay itself (a library call returning its measurements); RunReplay is
// the command, which prints them and writes the optional files. `tether bench --replay`
// (replay_bench.h) calls ReplayFile too.
#include <cstddef>
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

#include "tether/core/output_file.h"
#include "tether/solvers/fixed_lag_smoother.h"
#include "tether/solvers/incremental_smoother.h"

namespace tether {

/// How to replay a file.
struct ReplayOptions {
  int every = 1;  ///< update the smoother every N-th step (at least 1)
  int check = 0;  ///< every K-th update, solve the graph so far in batch (untimed); 0: never
  /// The smoother's options (re-linearisation, rounds, wildfire; checked by IsValid).
  SmootherOptions smoother;
  /// Where given, the final estimate and the graph are written here as g2o after Finish
  /// (through tether's output writer: a temporary file renamed into place); the path is checked
  /// before the replay starts; a failure is kWriteFailed.
  std::string output;
  /// Where set (not owned), the final estimate is staged into it instead of written to
  /// `output`, for the caller to commit together with its other outputs.
  OutputFile* output_file = nullptr;
  /// Replay through FixedLagSmoother (`--mode fixed-lag`): variables older than `lag` steps
  /// are marginalised, in batches of lag_batch * lag (FixedLagOptions::lag, ::batch), with
  /// `smoother` as the window's smoother. A factor that reaches a marginalised variable (a
  /// loop closure older than the lag) is left out and counted. The final estimate is each
  /// variable's last: when it left the window, or the window's after Finish(); final_chi2 is
  /// the whole file's chi2 there (the factors left out included), against the batch optimum.
  bool fixed_lag = false;
  /// After each update, time Marginal() of the variable that step added (the newest pose;
  /// not counted in the update's latency): ReplayResult::marginal_*.
  bool time_marginal = false;
  double lag = 100;
  double lag_batch = 0.25;

  /// True when the options can be used; otherwise says why (when `why` is not null).
  bool IsValid(std::string* why) const;
};

/// One --check: after the update at `step`, the online chi2 of the graph so far at the
/// smoother's estimate (computed from graph() and Estimate(), not taken from the update) and
/// the batch optimum of that graph from the same start.
struct ReplayCheck {
  std::size_t step = 0;    ///< the step (0-based pose index) whose update was checked
  double online_chi2 = 0;  ///< smoother.graph().Chi2(smoother.Estimate())
  double batch_chi2 = 0;   ///< Optimize(graph so far, from the estimate, options.finish)
  double gap = 0;          ///< RelativeChi2Gap(online_chi2, batch_chi2)
};

/// How a replay ended.
enum class ReplayStatus {
  kDone,
  kBadUsage,     ///< invalid ReplayOptions or smoother options
  kBadInput,     ///< the file could not be read, or an update was refused
  kSolveFailed,  ///< an update's solve, Finish or the batch solve failed
  kWriteFailed,  ///< the output cannot be written (checked before the replay) or writing it failed
};

/// The measurements of one replay. Times are wall-clock seconds.
struct ReplayResult {
  ReplayStatus status = ReplayStatus::kDone;
  std::string message;                ///< what went wrong (status other than kDone)
  std::vector<std::string> warnings;  ///< the reader's warnings about the file

  std::size_t variables = 0;  ///< every variable of the file (one step each)
  std::size_t poses = 0;      ///< SE2 and SE3 variables
  std::size_t factors = 0;

  /// The latency of every Update call, in order, and the step (0-based) each was made at.
  std::vector<double> latencies;
  std::vector<std::size_t> update_steps;
  /// Summed over the updates (SmootherUpdate's fields): updates that solved, that rebuilt the
  /// whole factor, that fell back to a batch solve; factorise-solve rounds; columns refactored;
  /// columns back-substituted; variables re-linearised.
  int solves = 0, rebuilt = 0, fell_back = 0, iterations = 0;
  /// SmootherMode::kLocal: updates solved in batch, and the variables of the local regions
  /// (summed over the updates solved locally).
  int batches = 0;
  long long region_variables = 0;
  long long affected_columns = 0, back_substituted = 0, relinearized = 0;
  /// The updates' split, summed (SmootherUpdate's fields).
  double linearize_seconds = 0, factorize_seconds = 0, solve_seconds = 0;
  double updates_seconds = 0;  ///< the sum of the latencies
  double finish_seconds = 0;   ///< Finish()

  /// Latency statistics over the updates: mean, p99 (nearest rank: the smallest latency that
  /// at least 99% of the updates do not exceed), max. 0 without updates.
  double mean_seconds = 0, p99_seconds = 0, max_seconds = 0;

  double final_chi2 = 0;    ///< after Finish()
  double batch_chi2 = 0;    ///< the batch optimum of the whole file (chordal start)
  double relative_gap = 0;  ///< RelativeChi2Gap(final_chi2, batch_chi2)
  std::vector<ReplayCheck> checks;
  double max_check_gap = 0;  ///< the largest ReplayCheck::gap (0 without checks)

  /// The process's peak resident set (getrusage ru_maxrss) right after Finish(), before the
  /// batch comparison solve: reading the file, the smoother, its solves (and the --check
  /// solves, where asked for), and whatever the process held before the replay. MiB.
  double peak_rss_mib = 0;

  /// Fixed lag: variables marginalised, factors left out (they reached a marginalised
  /// variable), and the largest window (variables) after an update.
  std::size_t marginalized = 0, beyond_lag = 0, largest_window = 0;
  /// time_marginal: how many Marginal() calls were timed, their summed and largest time.
  std::size_t marginals = 0;
  double marginal_seconds = 0, marginal_max_seconds = 0;

  double total_seconds() const { return updates_seconds + finish_seconds; }
};

/// (online - batch) / batch, with chi2 below 1e-6 counted as 1e-6 (a graph of odometry alone
/// has chi2 0 at its optimum, where any rounding would be an infinite relative gap).
double RelativeChi2Gap(double online, double batch);

/// The peak resident set of this process so far (getrusage ru_maxrss), MiB.
double PeakRssMib();

/// Replays `file` (see above). Never throws for bad input or failed solves: the status and
/// message say what happened, and the measurements up to there are filled in. `on_check`, where
/// given, is called after each check as it happens (for progress output).
ReplayResult ReplayFile(const std::string& file, const ReplayOptions& options,
                        const std::function<void(const ReplayCheck&)>& on_check = {});

struct ReplayCommand {
  std::string input;
  ReplayOptions options;
  std::string plot;    ///< SVG of every update's latency (optional; latency_plot.h)
  bool quiet = false;  ///< only the summary lines
};

/// Exit codes: 0 done; 1 bad input (unreadable file, an update refused, a file that cannot be
/// written); 2 bad usage; 3 a solve failed.
int RunReplay(const ReplayCommand& cmd, std::ostream& out, std::ostream& err);

}  // namespace tether
