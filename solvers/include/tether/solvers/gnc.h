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
// max(s / c^2) is taken over the loop closures at the least-squares solution the method
// starts from. At the end each loop closure's weight is rho'(s) in [0, 1], and one whose
// weight is below `reject_below` is rejected (after Yang, Antonante, Tzoumas and Carlone,
// "Graduated Non-Convexity for Robust Spatial Perception", 2020). The estimate is then the
// least-squares solution over the closures kept (from the stages' solution, or from DCS's
// where that costs less: dcs_candidate); a rejected closure that this map explains
// within its bound (chi2 <= c^2) is taken back and the map solved again (the robust cost can
// prefer to give up a true closure: measured on simulated worlds, GM gave up 2 of 39).
#include <string>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/values.h"
#include "tether/solvers/solver_options.h"

namespace tether {

enum class GncKernel { kGemanMcClure, kTruncatedLeastSquares };

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
  /// Also solve with DCS (dcs:1) on the loop closures from the given values, and keep that
  /// solution where its cost under the final surrogate is lower (GncSummary::from_dcs).
  /// Default on: the stages start from least squares, which enough false closures bend into
  /// a basin they do not leave (benchmarks/RESULTS.md, "Outlier benchmark").
  bool dcs_candidate = true;
  /// Each stage's solve (and the least-squares start): Levenberg-Marquardt, at most 30
  /// iterations by default.
  SolverOptions inner;

  GncOptions();
  bool IsValid(std::string* why) const;
};

struct GncSummary {
  SolverSummary start;  ///< the least-squares solve GNC starts from
  SolverSummary last;   ///< the last stage's solve
  int stages = 0;
  double mu = 0;  ///< mu at the end
  /// Per factor of the graph: rho'(s) at the last stage for a loop closure (1 for one taken
  /// back), else 1.
  std::vector<double> weights;
  std::vector<std::size_t> rejected;  ///< indices (in the graph) of the rejected loop closures
  int readmitted = 0;                 ///< closures below reject_below that the final map explains
  /// With dcs_candidate: the final surrogate cost of the stages' solution and of DCS's, and
  /// whether DCS's was kept.
  double gnc_cost = 0, dcs_cost = 0;
  bool from_dcs = false;
  int loop_closures = 0;
  double seconds = 0;
  std::string message;  ///< empty when usable; else why not
  bool usable = false;
};

/// Runs GNC on the loop closures of `graph` from *values; *values receives the result.
/// Throws InvalidArgument for invalid options.
GncSummary OptimizeGnc(const FactorGraph& graph, Values* values, const GncOptions& options = GncOptions());

}  // namespace tether
