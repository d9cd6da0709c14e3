#pragma once
// Graduated non-convexity (GNC) for loop closures: a solve that holds when many loop closures
// are wrong, where a robust loss alone (which starts from the least-squares answer the wrong
// closures have already bent) does not.
//
// The loop closures (Factor::loop_closure) get a surrogate of a robust loss whose shape is
// controlled by mu: convex at the start (where every closure weighs about as in least
// squares), and the loss itself at the end. Each stage solves from the previous stage's
// values (Optimize with `inner`), then mu moves by `mu_factor`. Odometry and every other
// factor stay quadratic (or keep a loss they carry).
//
//   kGemanMcClure:          rho_mu(s) = mu c^2 s / (mu c^2 + s); mu from 2 max(s / c^2) down
//                           to 1 (divided by mu_factor each stage): Geman-McClure with scale c.
//   kTruncatedLeastSquares: the surrogate of min(s, c^2) (s below mu / (mu + 1) c^2, c^2
//                           above (mu + 1) / mu c^2, 2 c sqrt(mu (mu + 1) s) - mu (c^2 + s)
//                           between); mu from 1 / (2 max(s / c^2) - 1) up (times mu_factor
//                           each stage) until every weight is 0 or 1.
//
// Where the stages start (GncOptions::start):
//   kChunkedDcs (default): DCS on the loop closures, solved chunk by chunk in time
//     order (chunked_solve.h), so that each closure is judged against a map built from the
//     closures before it. DCS's phi is learned as the chunks go: max(1, min(k c^2, c^2)), k the
//     median chi2 of the closures kept so far over the median of the chi2 distribution of their
//     dimension (phi 1, the literature's, where closures fit far below their stated noise, as
//     in the public files; c^2 where they fit as stated, as in simulated worlds, where phi 1
//     would give up true closures); 0.3 c^2 until k is learned (from 10 kept closures).
//     max(s / c^2) is then taken over the closures that start keeps (DCS weight at least
//     reject_below): the stages refine the start instead of undoing it (with the wrong
//     closures' residuals, mu_0 would make the first stage least squares again). Where the
//     stages' result costs more under the final surrogate than the start, the start
//     is kept (GncSummary::kept_start).
//   kLeastSquares: the classic start (Yang, Antonante, Tzoumas and Carlone, "Graduated
//     Non-Convexity for Robust Spatial Perception", 2020): least squares over every closure,
//     max(s / c^2) over all of them. Enough false closures bend least squares into a basin the
//     stages do not leave (benchmarks/RESULTS.md, "Outlier benchmark").
//
// At the end each loop closure's weight is rho'(s) in [0, 1], and one whose weight is below
// `reject_below` is rejected. The estimate is then the least-squares solution over the
// closures kept; a rejected closure that this map explains within its bound (chi2 <= c^2) is
// taken back and the map solved again (the robust cost can prefer to give up a true closure:
// measured on simulated worlds, GM gave up 2 of 39).
#include <string>
#include <vector>

#include "tether/core/enum_names.h"
#include "tether/core/factor_graph.h"
#include "tether/core/values.h"
#include "tether/solvers/chunked_solve.h"
#include "tether/solvers/solver_options.h"

namespace tether {

enum class GncKernel { kGemanMcClure, kTruncatedLeastSquares };
inline constexpr EnumName<GncKernel> kGncKernelNames[] = {{GncKernel::kGemanMcClure, "gm"},
                                                          {GncKernel::kTruncatedLeastSquares, "tls"}};
constexpr const auto& EnumNames(GncKernel) { return kGncKernelNames; }
enum class GncStart { kChunkedDcs, kLeastSquares };
inline constexpr EnumName<GncStart> kGncStartNames[] = {{GncStart::kChunkedDcs, "chunked"},
                                                        {GncStart::kLeastSquares, "least-squares"}};
constexpr const auto& EnumNames(GncStart) { return kGncStartNames; }

struct GncOptions {
  /// Default Geman-McClure: on simulated Manhattan worlds it kept every true closure where TLS
  /// rejected some (docs/solvers.md, "Graduated non-convexity").
  GncKernel kernel = GncKernel::kGemanMcClure;
  /// The inlier bound c^2 on a loop closure's squared whitened error (its chi2): beyond it a
  /// closure counts as an outlier (TLS), or weighs less than a quarter (GM). By default the
  /// `inlier_probability` quantile of the chi2 distribution with the closure's dimension
  /// (0.99: 9.2 for 2, 11.3 for 3, 16.8 for 6 dimensions; Wilson-Hilferty's approximation,
  /// within 1%); `c` above 0 sets c (not squared) for every closure instead.
  double inlier_probability = 0.99;
  double c = 0;
  /// How fast mu moves per stage. Default 1.4.
  double mu_factor = 1.4;
  /// At most this many stages. Default 1000.
  int max_stages = 1000;
  /// A loop closure whose final weight is below this is rejected. Default 0.1.
  double reject_below = 0.1;
  /// Where the stages start (above). Default kChunkedDcs.
  GncStart start = GncStart::kChunkedDcs;
  /// The chunks of the kChunkedDcs start (10 chunks of at least 50 poses, each solve at most
  /// 30 LM iterations, the ones before the last to a relative cost decrease of 1e-5, by
  /// default). GNC sets its own before_solve (one given here is replaced).
  ChunkedSolveOptions chunked;
  /// Each stage's solve (and the least-squares start): Levenberg-Marquardt, at most 30
  /// iterations by default.
  SolverOptions inner;
  /// The stages' iteration limit by default (a stage follows mu; it need not converge).
  static constexpr int kStageIterations = 30;

  GncOptions();
  /// Each stage solves with `solver`'s settings (step strategy, linear solver, threads, time
  /// limit, callback), at most kStageIterations iterations (fewer where `solver` says so).
  void SetSolver(const SolverOptions& solver);
  bool IsValid(std::string* why) const;
};

struct GncSummary {
  SolverSummary start;  ///< the solve GNC starts from (kChunkedDcs: the last chunk's)
  SolverSummary last;   ///< the last stage's solve
  int stages = 0;
  double mu = 0;  ///< mu at the end
  /// Per factor of the graph: rho'(s) at the last stage for a loop closure (1 for one taken
  /// back), else 1.
  std::vector<double> weights;
  std::vector<std::size_t> rejected;  ///< indices (in the graph) of the rejected loop closures
  int readmitted = 0;                 ///< closures below reject_below that the final map explains
  /// Closures the chunked start rejected and the stages kept, and closures held out of the
  /// stages that the final map leaves within 100 times their bound (times min(1, 10 k)): judged
  /// with the map's covariance. A closure the start kept and the stages rejected is simply
  /// rejected.
  int doubtful = 0;
  int held_out = 0;  ///< closures the chunked start rejected beyond 10 c^2, left out of the stages
  /// Seconds of the start, of the stages and of the final least squares with readmission.
  double start_seconds = 0, stages_seconds = 0, final_seconds = 0;
  /// The final surrogate's cost at the start and after the stages; kept_start where the
  /// start cost less and was kept.
  double start_cost = 0, stages_cost = 0;
  bool kept_start = false;
  int start_iterations = 0;  ///< iterations of the start (over every chunk)
  /// kChunkedDcs: the scale k learned for DCS's phi = max(1, min(k c^2, c^2)) (0: not learned,
  /// phi max(1, 0.3 c^2)).
  double phi_scale = 0;
  int loop_closures = 0;
  double seconds = 0;
  std::string message;  ///< empty when usable; else why not
  bool usable = false;
};

/// Runs GNC on the loop closures of `graph` from *values; *values receives the result.
/// Throws InvalidArgument for invalid options.
GncSummary OptimizeGnc(const FactorGraph& graph, Values* values, const GncOptions& options = GncOptions());

}  // namespace tether
