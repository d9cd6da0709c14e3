#pragma once
// Switchable constraints as a solve (Sünderhauf and Protzel, IROS 2012): every loop closure
// (Factor::loop_closure) of a graph gets a switch variable s (tether/factors/switchable.h) with
// the prior s = 1, its error scaled by psi(s) = clamp(s, 0, 1), and the augmented graph is
// solved once; odometry and every other factor stay as they are. A closure's weight is then
// psi(s)^2 (the factor's share of its plain chi2), and one whose weight is below
// `reject_below` counts as rejected. The switches live only inside the solve: the values
// handed back hold the graph's own variables.
#include <string>
#include <vector>

#include "tether/core/factor_graph.h"
#include "tether/core/values.h"
#include "tether/solvers/solver_options.h"

namespace tether {

struct SwitchableOptions {
  /// The switch prior's standard deviation (Sünderhauf's Xi = 1 / sigma^2): a switch at 0
  /// costs 1 / sigma^2, and at the optimum a closure of chi2 x keeps the weight
  /// psi^2 = (1 / (1 + x sigma^2))^2. Above 0: that sigma for every closure (Sünderhauf's
  /// choice is 1). 0 (the default): 1 / sigma^2 is the `inlier_probability` quantile of the
  /// chi2 distribution of the closure's dimension (11.3 for SE2, 16.8 for SE3 at 0.99), the
  /// bound GNC uses: Xi = 1 suits closures whose chi2 at the optimum is far below 1, and
  /// switches off true ones where it is about their dimension (docs/solvers.md).
  double prior_sigma = 0.0;
  double inlier_probability = 0.99;
  /// A loop closure whose final weight psi(s)^2 is below this is rejected. Default 0.1.
  double reject_below = 0.1;
  /// After the switched solve, solve again over the closures kept (from the switched
  /// solution; least squares unless a closure carries a loss of its own), as GNC ends. Default on: switches that stay
  /// partly open (weights between reject_below and 1) bend the map; off gives the switched solution itself.
  bool refit = true;
  /// The solve over the augmented graph: Levenberg-Marquardt, at most 100 iterations by
  /// default (switches make the problem slower to converge than plain least squares).
  SolverOptions solver;
  /// The solve's iteration floor by default.
  static constexpr int kMinIterations = 100;

  SwitchableOptions();
  /// The switched solve takes `solver`'s settings (step strategy, linear solver, threads, time
  /// limit, callback), with at least kMinIterations iterations.
  void SetSolver(const SolverOptions& solver);
  bool IsValid(std::string* why) const;
};

struct SwitchableSummary {
  SolverSummary solve;  ///< the switched solve (its chi2 includes the switch priors)
  SolverSummary refit;  ///< with SwitchableOptions::refit: least squares over the kept closures
  /// Per factor of the graph: psi(s)^2 for a loop closure, else 1.
  std::vector<double> weights;
  /// Per factor of the graph: the switch's final value for a loop closure, else 1.
  std::vector<double> switches;
  std::vector<std::size_t> rejected;  ///< indices (in the graph) of the rejected loop closures
  int loop_closures = 0;
  double seconds = 0;
  bool usable = false;
  std::string message;  ///< empty when usable; else why not
};

/// `graph` with a switch on every loop closure: factor i of the result is factor i of `graph`
/// (a loop closure wrapped as a SwitchableFactor), and the switch priors follow (standard
/// deviation prior_sigma, or for 0 from the chi2 quantile as SwitchableOptions says). The switches'
/// keys run from one past the largest key of *values, in closure order, and go into *values
/// at 1; where `graph` has no anchor (nothing fixed, no one-key factor) its lowest-key pose is
/// fixed in the result, as the solvers would hold it (the switch priors would otherwise count
/// as anchors); `switch_keys` (if not null) receives them. Throws InvalidArgument where the keys
/// would run out or the options are not valid.
FactorGraph WithSwitches(const FactorGraph& graph, Values* values,
                         const SwitchableOptions& options = SwitchableOptions(),
                         std::vector<Key>* switch_keys = nullptr);

/// Solves `graph` with switchable loop closures from *values; *values receives the result (the
/// graph's own variables only). Throws InvalidArgument for invalid options.
SwitchableSummary OptimizeSwitchable(const FactorGraph& graph, Values* values,
                                     const SwitchableOptions& options = SwitchableOptions());

}  // namespace tether
