#pragma once
// The commands of the `tether` program, callable from tests. Each returns the process exit
// code and writes its report to `out` and errors to `err`.
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

#include "tether/solvers/pipeline.h"
#include "tether/tools/command.h"

namespace tether {

class OutputSet;
class PluginLoader;
/// Loads each plugin with `loader`, printing its summary to `out`; false after saying why on
/// `err` (the command then exits with kExitPluginFailed).
bool LoadPlugins(const std::vector<std::string>& plugins, PluginLoader* loader, std::ostream& out, std::ostream& err);

/// Runs `add`, which adds a command's outputs (and inputs) to `set`, and prints the set's notes;
/// 0, or the exit code after saying why: kExitUsage for outputs the arguments cannot have (an
/// empty path, an output naming an input or another output), kExitWriteFailed for a path that
/// cannot be written. `command` names the command in messages ("optimize").
int CheckOutputs(const std::string& command, OutputSet& set, const std::function<void()>& add, std::ostream& err);

/// `tether optimize`: the pipeline's options (bound to the flags directly: input, outputs,
/// plot, ground truth, covariances, robust rules, GNC or switchable constraints) and the few
/// words the command parses before the pipeline can take them.
struct OptimizeCommand {
  /// Everything the run does and writes. The solver's settings are in pipeline.solver, except
  /// its names (below).
  PipelineOptions pipeline;
  /// The step strategy's and the linear solver's names: a plugin's are known once it is loaded.
  std::string solver = "lm";    ///< gn | lm | dogleg | ceres | a plugin's
  std::string linear = "auto";  ///< auto | block | cholmod | ldlt | qr | a plugin's
  bool quiet = false;           ///< no iteration table
  /// Robust loss rules, SELECTOR=KERNEL:SCALE (loop=huber:1.0, all=cauchy:2, EDGE_SE2=dcs:1;
  /// tether/core/robust_rules.h), applied in order after reading (parsed into pipeline.robust
  /// once the plugins are loaded).
  std::vector<std::string> robust;
  std::vector<std::string> plugins;  ///< plugins to load first (paths or names)
  /// Marginal covariances after a successful solve: comma-separated ids, or "all" (every
  /// free variable); empty: none. Parsed into pipeline.covariance and covariance_keys.
  std::string covariance;
  /// With --linear petsc or petsc-iterative: PETSc's options, as on its command line
  /// ("-mat_mumps_icntl_14 50"; tether/solvers/distributed.h).
  std::string petsc_options;
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

/// The exit code `tether optimize` gives for a pipeline's status (command.h).
int ExitCodeOf(PipelineStatus status);

/// Exit codes: 0 solved; 1 bad input (nothing written); 2 bad usage; 3 the solver failed
/// (status says why; nothing written).
int RunOptimize(const OptimizeCommand& cmd, std::ostream& out, std::ostream& err);
int RunSimulate(const SimulateCommand& cmd, std::ostream& out, std::ostream& err);
/// Lists loaded plugins and every registered factor type (name, tag, dimensions, owner).
int RunPluginsList(const PluginsListCommand& cmd, std::ostream& out, std::ostream& err);

}  // namespace tether
