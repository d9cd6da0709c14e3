#pragma once
// The commands of the `tether` program, callable from tests. Each returns the process exit
// code and writes its report to `out` and errors to `err`.
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

#include "tether/solvers/solver_options.h"

namespace tether {

/// Exit codes of the `tether` program: 0 done; 1 bad input (the message names file:line); 2
/// bad usage (arguments); 3 the solve failed; 4 an output could not be written (nothing was
/// written); 5 a plugin could not be loaded.
constexpr int kExitBadInput = 1;
constexpr int kExitUsage = 2;
constexpr int kExitSolveFailed = 3;
constexpr int kExitWriteFailed = 4;
constexpr int kExitPluginFailed = 5;

class OutputSet;
/// Runs `add`, which adds a command's outputs (and inputs) to `set`, and prints the set's notes;
/// 0, or the exit code after saying why: kExitUsage for outputs the arguments cannot have (an
/// empty path, an output naming an input or another output), kExitWriteFailed for a path that
/// cannot be written. `command` names the command in messages ("optimize").
int CheckOutputs(const std::string& command, OutputSet& set, const std::function<void()>& add, std::ostream& err);

struct OptimizeCommand {
  std::string input;
  std::string output;              ///< g2o file with the optimised values (optional)
  std::string plot;                ///< SVG with the file's start, the result (and the truth) (optional)
  std::string ground_truth;        ///< g2o file with the true values: ATE reported and drawn (optional)
  std::string solver = "lm";       ///< gn | lm | ceres
  std::string linear = "cholmod";  ///< cholmod | ldlt | qr
  std::string init = "chordal";    ///< file | spanning-tree | chordal (see docs/initialisation.md)
  int max_iterations = 100;
  double time_limit = 0;                                                   ///< seconds, 0 for none
  int threads = 1;                                                         ///< SolverOptions::num_threads (1 to 256)
  int max_reuse_iterations = SolverOptions().linear.max_reuse_iterations;  ///< 0: factorise every step
  std::string repair_information = "none";                                 ///< none | nearest-pd | isotropic
  std::string format = "auto";  ///< auto | g2o | toro | isam (ReadOptions::format)
  /// iSAM files: sqrt-information (iSAM's reading) | covariance (ReadOptions::isam_noise).
  std::string isam_noise = "sqrt-information";
  bool quiet = false;                   ///< no iteration table
  bool allow_partial_vertices = false;  ///< compose missing vertices from edges instead of failing
  /// Robust loss rules, SELECTOR=KERNEL:SCALE (loop=huber:1.0, all=cauchy:2, EDGE_SE2=dcs:1;
  /// tether/core/robust_rules.h), applied in order after reading.
  std::vector<std::string> robust;
  /// Graduated non-convexity on the loop closures, with the kernel gnc_kernel (tls | gm).
  bool gnc = false;
  std::string gnc_kernel = "gm";
  std::string gnc_start = "chunked";  ///< chunked | least-squares (GncStart)
  /// Switchable constraints on the loop closures (a switch per closure); switch_prior_sigma
  /// above 0 sets the switch prior's sigma (0: from the chi2 quantile).
  bool switchable = false;
  double switch_prior_sigma = 0;
  /// With gnc or switchable: the rejected loop closures as g2o lines (default:
  /// OUTPUT.rejected.g2o where -o is given).
  std::string rejected_output;
  std::vector<std::string> plugins;  ///< factor plugins to load first (paths or names)
  /// Marginal covariances after a successful solve: comma-separated ids, or "all" (every
  /// free variable); empty: none. Written to covariance_output (default: output + ".cov").
  std::string covariance;
  std::string covariance_output;
};

struct PluginsListCommand {
  std::vector<std::string> plugins;  ///< plugins to load before listing
};

struct SimulateCommand {
  std::string world = "manhattan";  ///< manhattan | sphere | landmarks
  int poses = 500;
  unsigned long long seed = 1;
  std::string output;
  std::string ground_truth;  ///< optional g2o file with the true values
};

/// Exit codes: 0 solved; 1 bad input (nothing written); 2 bad usage; 3 the solver failed
/// (status says why; nothing written).
int RunOptimize(const OptimizeCommand& cmd, std::ostream& out, std::ostream& err);
int RunSimulate(const SimulateCommand& cmd, std::ostream& out, std::ostream& err);
/// Lists loaded plugins and every registered factor type (name, tag, dimensions, owner).
int RunPluginsList(const PluginsListCommand& cmd, std::ostream& out, std::ostream& err);

}  // namespace tether
