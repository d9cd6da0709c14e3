#include "tether/solvers/pipeline.h"

#include <chrono>
#include <cstdio>
#include <utility>

#include "tether/core/enum_names.h"
#include "tether/core/error.h"
#include "tether/core/output_file.h"
#include "tether/core/timing.h"
#include "tether/solvers/covariance.h"
#include "tether/solvers/optimizer.h"

namespace tether {

bool PipelineOptions::IsValid(std::string* why) const {
  std::string reason;
  if (input.empty()) {
    reason = "PipelineOptions.input is empty; name the graph file to read (.g2o, or TORO .graph)";
  } else if (!solver.IsValid(&reason)) {
    reason = "PipelineOptions.solver: " + reason;
  } else if (solver.algorithm == Algorithm::kCeres && !CeresRunsWith(solver.linear_solver)) {
    reason =
        "PipelineOptions.solver: the ceres algorithm solves with Ceres' SPARSE_NORMAL_CHOLESKY over SuiteSparse; "
        "use the auto or cholmod linear solver (block, ldlt and qr are for gn and lm)";
  } else if (gnc && !gnc_options.IsValid(&reason)) {
    reason = "PipelineOptions.gnc_options: " + reason;
  } else if (gnc && switchable) {
    reason = "PipelineOptions: gnc and switchable are two ways to solve; choose one";
  } else if (switchable && !switchable_options.IsValid(&reason)) {
    reason = "PipelineOptions.switchable_options: " + reason;
  } else if (!rejected_output.empty() && !gnc && !switchable) {
    reason = "PipelineOptions: rejected_output needs gnc or switchable (only they reject loop closures)";
  } else if (covariance && output.empty() && covariance_output.empty()) {
    reason =
        "PipelineOptions: covariance needs a file: covariance_output, or output (the covariances then go to "
        "OUTPUT.cov)";
  } else if (!covariance && (!covariance_output.empty() || !covariance_keys.empty())) {
    reason = "PipelineOptions: covariance_output and covariance_keys need covariance";
  } else if (!plot.IsValid(&reason)) {
    reason = "PipelineOptions.plot: " + reason;
  }
  if (why != nullptr) *why = reason;
  return reason.empty();
}

std::string PipelineOptions::RejectedPath() const {
  if (!gnc && !switchable) return "";
  return !rejected_output.empty() ? rejected_output : output.empty() ? "" : output + ".rejected.g2o";
}

std::string PipelineOptions::CovariancePath() const {
  if (!covariance) return "";
  return !covariance_output.empty() ? covariance_output : output + ".cov";
}

GraphFile ReadProblem(const PipelineOptions& options, const Registry& registry) {
  return ReadGraphFile(options.input, registry, options.read);
}

InitSummary InitializeProblem(const FactorGraph& graph, Values* values, InitMethod method, const std::string& name,
                              const LinearSolverType& linear_solver) {
  try {
    return Initialize(graph, values, method, linear_solver);
  } catch (const Error& e) {
    throw InvalidArgument(name + ": " + e.what());
  }
}

SolverSummary OptimizeProblem(const FactorGraph& graph, Values* values, const SolverOptions& options) {
  return Optimize(graph, values, options);
}

void WriteProblem(const std::string& path, const FactorGraph& graph, const Values& values, const Registry& registry) {
  WriteG2oFile(path, values, graph, registry);
}

std::string RejectedClosuresText(const FactorGraph& graph, const std::vector<std::size_t>& indices,
                                 const std::vector<double>& weights, const Registry& registry) {
  std::string text;
  for (std::size_t i : indices) {
    char weight[64];
    std::snprintf(weight, sizeof weight, "# factor %zu, weight %.3g\n", i, i < weights.size() ? weights[i] : 0.0);
    text += weight;
    try {
      text += registry.Write(graph.at(i)) + "\n";
    } catch (const Error& e) {
      text += "# (no g2o form: " + std::string(e.what()) + ")\n";
    }
  }
  return text;
}

namespace {

// Every output a run writes, checked before anything is read (paths usable, none naming an
// input or another output) and committed together.
struct PipelineOutputs {
  OutputSet set;
  OutputFile* graph = nullptr;
  OutputFile* rejected = nullptr;
  OutputFile* covariance = nullptr;
  OutputFile* plot = nullptr;
};

void AddOutputs(const PipelineOptions& options, PipelineOutputs* o) {
  o->set.AddInput(options.input, "input graph");
  if (!options.ground_truth.empty()) o->set.AddInput(options.ground_truth, "ground truth");
  for (const std::string& path : options.other_inputs) o->set.AddInput(path, "input");
  if (!options.output.empty()) o->graph = &o->set.Add(options.output, "optimised graph");
  if (!options.plot_output.empty()) o->plot = &o->set.Add(options.plot_output, "plot");
  if (const std::string path = options.RejectedPath(); !path.empty()) {
    o->rejected = &o->set.Add(path, "rejected loop closures");
  }
  if (options.covariance) o->covariance = &o->set.Add(options.CovariancePath(), "covariances");
}

// The solve the options ask for: one, GNC's stages, or the switches.
void Solve(const PipelineOptions& options, PipelineResult* r, Values* values) {
  if (options.gnc) {
    r->gnc = OptimizeGnc(r->file.graph, values, options.gnc_options);
    r->summary = r->gnc.last;
    if (!r->gnc.usable && r->summary.IsSolutionUsable()) {
      r->summary.status = SolverStatus::kDiverged;
      r->summary.message = r->gnc.message;
    }
  } else if (options.switchable) {
    r->switchable = OptimizeSwitchable(r->file.graph, values, options.switchable_options);
    r->summary = r->switchable.refit.IsSolutionUsable() ? r->switchable.refit : r->switchable.solve;
    if (!r->switchable.usable && r->summary.IsSolutionUsable()) {
      r->summary.status = SolverStatus::kDiverged;
      r->summary.message = r->switchable.message;
    }
  } else {
    r->summary = OptimizeProblem(r->file.graph, values, options.solver);
  }
}

// The marginal covariances at the solution. Throws (a singular system, an unknown key).
PipelineCovariances ComputeCovariances(const PipelineOptions& options, const PipelineResult& r) {
  CovarianceOptions co;
  if (options.solver.linear_solver == LinearSolverType::kEigenLDLT) co.linear_solver = "ldlt";
  if (options.solver.linear_solver == LinearSolverType::kQR) co.linear_solver = "qr";
  co.num_threads = options.solver.num_threads;
  PipelineCovariances c;
  const auto t0 = std::chrono::steady_clock::now();
  const Marginals marginals(r.file.graph, r.values, co);
  const auto t1 = std::chrono::steady_clock::now();
  c.keys = options.covariance_keys.empty() ? marginals.free_keys() : options.covariance_keys;
  c.matrices = marginals.MarginalsOf(c.keys);
  c.seconds = SecondsSince(t0);
  c.marginals_seconds = SecondsSince(t1);
  c.linearize_seconds = marginals.linearize_seconds();
  c.factorize_seconds = marginals.factorize_seconds();
  c.method = marginals.Description();
  return c;
}

// Computes what the outputs need and stages them; throws tether::Error.
void StageOutputs(const PipelineOptions& options, const Registry& registry, PipelineResult* r, PipelineOutputs* o) {
  if (o->graph != nullptr) o->graph->Stage([&](std::ostream& s) { WriteG2o(s, r->values, r->file.graph, registry); });
  if (o->rejected != nullptr) {
    const bool gnc = options.gnc;
    o->rejected->Stage(RejectedClosuresText(r->file.graph, gnc ? r->gnc.rejected : r->switchable.rejected,
                                            gnc ? r->gnc.weights : r->switchable.weights, registry));
  }
  if (o->covariance != nullptr) {
    o->covariance->Stage(
        [&](std::ostream& s) { WriteCovariances(s, r->values, r->covariances.keys, r->covariances.matrices); });
  }
  if (o->plot != nullptr) {
    PlotOptions plot = options.plot;
    if (plot.title.empty()) plot.title = options.input;
    const Values* truth = options.ground_truth.empty() ? nullptr : &r->truth;
    o->plot->Stage(RenderSvg(r->file.graph, &r->file.values, &r->values, truth, plot));
  }
}

}  // namespace

PipelineResult RunPipeline(const PipelineOptions& options, const Registry& registry, const PipelineHooks& hooks) {
  PipelineResult r;
  auto stop = [&r](PipelineStatus status, std::string message) {
    r.status = status;
    r.message = std::move(message);
    return std::move(r);
  };
  std::string why;
  if (!options.IsValid(&why)) return stop(PipelineStatus::kInvalidOptions, why);

  try {
    CheckRobustRules(options.robust, registry);  // a tag no type has: refused before reading
  } catch (const InvalidArgument& e) {
    return stop(PipelineStatus::kInvalidOptions, e.what());
  }
  // The outputs are checked before anything is read: a typo in a folder costs no solve.
  PipelineOutputs outputs;
  try {
    AddOutputs(options, &outputs);
  } catch (const IoError& e) {
    r.output_notes = outputs.set.Notes();
    return stop(PipelineStatus::kWriteFailed, std::string(e.what()) + "; nothing was read");
  } catch (const Error& e) {
    r.output_notes = outputs.set.Notes();
    return stop(PipelineStatus::kInvalidOptions, e.what());
  }
  r.output_notes = outputs.set.Notes();
  auto t0 = std::chrono::steady_clock::now();
  try {
    if (!options.ground_truth.empty()) r.truth = ReadGraphFile(options.ground_truth, registry).values;
    r.file = ReadProblem(options, registry);
  } catch (const Error& e) {
    return stop(PipelineStatus::kBadInput, e.what());
  }
  r.times.read = SecondsSince(t0);
  ApplyRobustRules(options.robust, registry, &r.file.graph);
  if (hooks.on_read) hooks.on_read(r.file);

  // Where the file's start is kept, it stays in r.file.values and the initialisation and
  // solve work on copies; otherwise the values move from stage to stage.
  const bool keep = options.keep_intermediate_values || !options.plot_output.empty() || !options.ground_truth.empty();
  Values values = keep ? r.file.values : std::move(r.file.values);
  if (!keep) r.file.values = Values();
  t0 = std::chrono::steady_clock::now();
  try {
    r.init = InitializeProblem(r.file.graph, &values, options.init, options.input, options.solver.linear_solver);
  } catch (const Error& e) {
    return stop(PipelineStatus::kBadInput, e.what());
  }
  r.times.initialize = SecondsSince(t0);
  r.initialized = true;
  if (keep) r.initial = values;
  if (hooks.on_initialized) hooks.on_initialized(r.init);

  t0 = std::chrono::steady_clock::now();
  Solve(options, &r, &values);
  r.times.optimize = SecondsSince(t0);
  r.optimized = true;
  r.values = std::move(values);
  if (hooks.on_optimized) hooks.on_optimized(r.summary);
  if (!r.summary.IsSolutionUsable()) {
    return stop(PipelineStatus::kSolveFailed, "the solve failed (" + std::string(ToString(r.summary.status)) +
                                                  "): " + r.summary.message + "; no output written");
  }
  if (!options.ground_truth.empty()) {
    r.start_error = AbsoluteTrajectoryError(r.file.values, r.truth);
    r.result_error = AbsoluteTrajectoryError(r.values, r.truth);
  }
  if (options.covariance) {
    try {
      r.covariances = ComputeCovariances(options, r);
      r.times.covariance = r.covariances.seconds;
    } catch (const IoError& e) {
      return stop(PipelineStatus::kWriteFailed, std::string(e.what()) + "; nothing was written");
    } catch (const Error& e) {
      return stop(PipelineStatus::kBadInput, "covariance: " + std::string(e.what()) + "; nothing was written");
    }
  }
  t0 = std::chrono::steady_clock::now();
  try {
    StageOutputs(options, registry, &r, &outputs);
  } catch (const Error& e) {
    return stop(PipelineStatus::kWriteFailed, std::string(e.what()) + "; nothing was written");
  }
  try {
    outputs.set.CommitAll();  // all or nothing; its message says what became of the files
  } catch (const Error& e) {
    return stop(PipelineStatus::kWriteFailed, e.what());
  }
  r.times.write = SecondsSince(t0);
  for (const OutputFile* f : {outputs.graph, outputs.rejected, outputs.covariance, outputs.plot}) {
    if (f != nullptr && f->committed()) r.written_paths.push_back(f->path());
  }
  r.written = !r.written_paths.empty();
  r.status = PipelineStatus::kOk;
  return r;
}

}  // namespace tether
