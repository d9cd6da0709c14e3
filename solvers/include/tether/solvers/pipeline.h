#pragma once
// The whole job as library calls: read a graph file (any registered format: g2o, TORO),
// initialise, optimise, write. `tether optimize` parses its arguments into PipelineOptions and
// calls RunPipeline; Python and front-ends call the same code and get the same result (the
// same final chi2, the same output bytes).
//
//   PipelineOptions options;
//   options.input = "intel.g2o";
//   options.output = "intel_optimized.g2o";
//   const PipelineResult r = RunPipeline(options, DefaultRegistry());
//   if (!r.ok()) std::cerr << r.message << "\n";
//
// The stages are also callable one at a time (ReadProblem, InitializeProblem, OptimizeProblem,
// WriteProblem); they throw where RunPipeline reports. docs/pipeline.md has more.
#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "tether/core/graph_io.h"
#include "tether/core/registry.h"
#include "tether/core/robust_rules.h"
#include "tether/core/svg_plot.h"
#include "tether/core/trajectory_error.h"
#include "tether/core/values.h"
#include "tether/solvers/gnc.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/solver_options.h"
#include "tether/solvers/switchable.h"

namespace tether {

struct PipelineOptions {
  /// The graph file to read (g2o, or TORO 2D; `read.format` says which, kAuto by default).
  std::string input;
  /// How to read it: format, repair of information matrices that are not positive
  /// definite, composition of missing vertices (graph_io.h; defaults: automatic format, no
  /// repair, every vertex must be given unless the file has none).
  ReadOptions read;
  /// The initial guess the solve starts from (initialize.h). Default: chordal relaxation.
  InitMethod init = InitMethod::kChordal;
  /// The nonlinear solve (solver_options.h; Levenberg-Marquardt over CHOLMOD by default).
  /// Its callback, if set, is called after every iteration as usual.
  SolverOptions solver;
  /// Where to write the optimised graph as g2o; empty (the default): nothing is written.
  /// Written only when the solve succeeds, through a temporary file renamed into place.
  /// Every output of a run (this one and the four below) is checked before the input is read
  /// and committed together once all are made: all are written, or none is replaced.
  std::string output;
  /// With gnc or switchable: where to write the loop closures they reject, as g2o lines each
  /// after a comment with its factor index and weight. Empty (the default): `output` +
  /// ".rejected.g2o" where `output` is given, else nothing.
  std::string rejected_output;
  /// Marginal covariances at the solution (covariance.h), written by WriteCovariances. Off by
  /// default. They use the solve's linear solver where it is ldlt or qr (cholmod otherwise)
  /// and its threads; a singular system (a free gauge) ends the run as kBadInput.
  bool covariance = false;
  /// With covariance: the variables, in this order; empty (the default): every free variable.
  std::vector<Key> covariance_keys;
  /// With covariance: the file; empty (the default): `output` + ".cov" (one of the two is needed).
  std::string covariance_output;
  /// Other files the run reads (plugins): no output may name one.
  std::vector<std::string> other_inputs;
  /// A g2o file of the true values (empty: none): the result gets the absolute trajectory
  /// error of the file's start and of the result, and the plot draws the truth.
  std::string ground_truth;
  /// Where to write an SVG of the file's start and the result (and the truth); empty: none.
  std::string plot_output;
  /// How the plot is drawn; an empty title is the input's path.
  PlotOptions plot;
  /// Keep the file's own start (PipelineResult::file.values) and the solve's start
  /// (PipelineResult::initial) beside the result: two more copies of the values, for plots
  /// and comparisons. Off (the default): the values are moved from stage to stage, the
  /// result's `values` is the only copy, and `file.values` and `initial` are left empty
  /// (a plot or a ground truth keeps them: both need the file's start).
  bool keep_intermediate_values = false;
  /// Robust loss rules applied to the graph after reading (tether/core/robust_rules.h; empty:
  /// none, every factor plain least squares). A tag no registered type has is
  /// kInvalidOptions, before the file is read.
  std::vector<RobustRule> robust;
  /// Graduated non-convexity on the loop closures (gnc.h) instead of one solve; `solver`
  /// is then not used (gnc_options.inner is each stage's solve).
  bool gnc = false;
  GncOptions gnc_options;
  /// Switchable constraints on the loop closures (switchable.h) instead of one solve; `solver`
  /// is then not used (switchable_options.solver is). Not together with gnc.
  bool switchable = false;
  SwitchableOptions switchable_options;

  /// True when the options can be used; otherwise says why (when `why` is not null).
  bool IsValid(std::string* why) const;
  /// The files the options name: the rejected closures' and the covariances' after their
  /// defaults (empty where none is written).
  std::string RejectedPath() const;
  std::string CovariancePath() const;
};

/// What the covariance stage computed (PipelineOptions::covariance).
struct PipelineCovariances {
  std::vector<Key> keys;                  ///< the variables, in the file's order
  std::vector<Eigen::MatrixXd> matrices;  ///< one per key, in its tangent coordinates
  double seconds = 0;                     ///< the whole stage
  double linearize_seconds = 0, factorize_seconds = 0, marginals_seconds = 0;
  std::string method;  ///< Marginals::Description()
};

/// How a pipeline run ended.
enum class PipelineStatus {
  kOk,              ///< solved (a usable SolverStatus) and the output, if any, written
  kInvalidOptions,  ///< PipelineOptions::IsValid failed; nothing was read
  kBadInput,        ///< a file could not be read, the graph initialised or its covariances computed; nothing written
  kSolveFailed,     ///< the solver's status is not usable (summary says why); nothing written
  kWriteFailed,     ///< the output cannot be written (checked before reading) or writing it failed; nothing written
};

inline constexpr EnumName<PipelineStatus> kPipelineStatusNames[] = {
    {PipelineStatus::kOk, "ok"},
    {PipelineStatus::kInvalidOptions, "invalid-options"},
    {PipelineStatus::kBadInput, "bad-input"},
    {PipelineStatus::kSolveFailed, "solve-failed"},
    {PipelineStatus::kWriteFailed, "write-failed"}};
constexpr const auto& EnumNames(PipelineStatus) { return kPipelineStatusNames; }

/// What happened, stage by stage. Stages not reached keep their defaults.
/// Wall seconds of the pipeline's stages (0 for a stage not reached). The solve's own split
/// (symbolic setup, linearise, factorise, triangular solves) is in SolverSummary.
struct PipelineTimes {
  double read = 0;        ///< reading the graph file (and the ground truth)
  double initialize = 0;  ///< the initial guess (InitMethod)
  double optimize = 0;    ///< the solve, GNC's stages or the switches
  double covariance = 0;  ///< the marginal covariances
  double write = 0;       ///< formatting the outputs and committing them
  /// The stages together.
  double Total() const { return read + initialize + optimize + covariance + write; }
};

struct PipelineResult {
  PipelineStatus status = PipelineStatus::kInvalidOptions;
  /// Empty when status is kOk; otherwise one line saying what went wrong, where (file:line
  /// for a bad file) and what to do.
  std::string message;
  /// The file as read: graph, values (the file's own start, before initialisation: a file
  /// without vertices has had them composed along a spanning tree; kept only with
  /// keep_intermediate_values), warnings, repairs.
  GraphFile file;
  /// Reached the initialisation, and what it did.
  bool initialized = false;
  InitSummary init;
  /// Where the solve started (after initialisation; kept only with keep_intermediate_values).
  Values initial;
  /// Reached the solve, and its summary.
  bool optimized = false;
  SolverSummary summary;
  /// With PipelineOptions::gnc: what GNC did (summary is its last stage's).
  GncSummary gnc;
  /// With PipelineOptions::switchable: what the switches did (summary is the last solve's).
  SwitchableSummary switchable;
  /// The solver's values (the result where the solve succeeded; the last good values
  /// otherwise).
  Values values;
  /// With PipelineOptions::ground_truth: the truth as read, and the absolute trajectory
  /// error of the file's start and of the result against it (poses == 0 where they share no
  /// pose).
  Values truth;
  TrajectoryError start_error, result_error;
  /// With PipelineOptions::covariance: what was computed.
  PipelineCovariances covariances;
  /// Every output was written (there was at least one).
  bool written = false;
  /// The files written, in the order graph, rejected closures, covariances, plot.
  std::vector<std::string> written_paths;
  /// Notes on the outputs' folders, to print: an earlier run's commit that was interrupted
  /// and has now been finished or undone (OutputSet::Notes).
  std::vector<std::string> output_notes;
  /// Where the time went.
  PipelineTimes times;

  bool ok() const { return status == PipelineStatus::kOk; }
};

/// Called between the stages of RunPipeline, for progress reports (the CLI prints its lines
/// from them). Any may be empty.
struct PipelineHooks {
  std::function<void(const GraphFile&)> on_read;           ///< after reading, before initialising
  std::function<void(const InitSummary&)> on_initialized;  ///< after initialising, before solving
  std::function<void(const SolverSummary&)> on_optimized;  ///< after solving, before writing
};

/// Reads `options.input` with `options.read`; throws ParseError ("file:line: ...") or IoError.
GraphFile ReadProblem(const PipelineOptions& options, const Registry& registry);
/// Replaces `values` with the initial guess of `method` (Initialize). Throws InvalidArgument
/// starting "name: " where the graph cannot be initialised; the values are then untouched.
/// `linear_solver`: the solve's, which the chordal start uses where it spans processes.
InitSummary InitializeProblem(const FactorGraph& graph, Values* values, InitMethod method, const std::string& name,
                              const LinearSolverType& linear_solver = LinearSolverType::kAuto);
/// Optimises `values` over `graph` (Optimize; the summary's status says whether it worked).
SolverSummary OptimizeProblem(const FactorGraph& graph, Values* values, const SolverOptions& options);
/// Writes the graph with `values` as g2o to `path` (temporary file renamed). Throws IoError.
void WriteProblem(const std::string& path, const FactorGraph& graph, const Values& values, const Registry& registry);
/// The loop closures GNC or the switches rejected (`indices` into `graph`, `weights` by factor
/// index), as g2o lines each after a comment with its index and weight: the text of
/// PipelineOptions::rejected_output.
std::string RejectedClosuresText(const FactorGraph& graph, const std::vector<std::size_t>& indices,
                                 const std::vector<double>& weights, const Registry& registry);

/// Reads, initialises, optimises, computes what was asked (covariances, trajectory error) and
/// writes every output together, as `tether optimize` does. Bad options, a bad file and an
/// output that cannot be written are reported in the result's status and message, never
/// thrown (only what is not a tether::Error, such as std::bad_alloc, escapes).
PipelineResult RunPipeline(const PipelineOptions& options, const Registry& registry, const PipelineHooks& hooks = {});

}  // namespace tether
