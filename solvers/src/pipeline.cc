#include "tether/solvers/pipeline.h"

#include <utility>

#include "tether/core/enum_names.h"
#include "tether/core/error.h"
#include "tether/core/output_file.h"
#include "tether/solvers/optimizer.h"

namespace tether {

bool PipelineOptions::IsValid(std::string* why) const {
  std::string reason;
  if (input.empty()) {
    reason = "PipelineOptions.input is empty; name the graph file to read (.g2o, or TORO .graph)";
  } else if (!solver.IsValid(&reason)) {
    reason = "PipelineOptions.solver: " + reason;
  } else if (solver.algorithm == Algorithm::kCeres && solver.linear_solver != LinearSolverType::kCholmod) {
    reason =
        "PipelineOptions.solver: the ceres algorithm solves with Ceres' SPARSE_NORMAL_CHOLESKY over SuiteSparse; "
        "use the cholmod linear solver (ldlt and qr are for gn and lm)";
  } else if (gnc && !gnc_options.IsValid(&reason)) {
    reason = "PipelineOptions.gnc_options: " + reason;
  } else if (gnc && switchable) {
    reason = "PipelineOptions: gnc and switchable are two ways to solve; choose one";
  } else if (switchable && !switchable_options.IsValid(&reason)) {
    reason = "PipelineOptions.switchable_options: " + reason;
  }
  if (why != nullptr) *why = reason;
  return reason.empty();
}

GraphFile ReadProblem(const PipelineOptions& options, const Registry& registry) {
  return ReadGraphFile(options.input, registry, options.read);
}

InitSummary InitializeProblem(const FactorGraph& graph, Values* values, InitMethod method, const std::string& name) {
  try {
    return Initialize(graph, values, method);
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
  // The output is checked before anything is read: a typo in its folder costs no solve.
  OutputSet outputs;
  OutputFile* output = nullptr;
  if (!options.output.empty()) {
    try {
      outputs.AddInput(options.input, "input graph");
      output = &outputs.Add(options.output, "optimised graph");
    } catch (const IoError& e) {
      return stop(PipelineStatus::kWriteFailed, std::string(e.what()) + "; nothing was read");
    } catch (const Error& e) {
      return stop(PipelineStatus::kInvalidOptions, e.what());
    }
  }
  try {
    r.file = ReadProblem(options, registry);
  } catch (const Error& e) {
    return stop(PipelineStatus::kBadInput, e.what());
  }
  ApplyRobustRules(options.robust, registry, &r.file.graph);
  if (hooks.on_read) hooks.on_read(r.file);

  // With keep_intermediate_values the file's own start stays in r.file.values and the
  // initialisation and solve work on copies; without, the values move from stage to stage.
  Values values = options.keep_intermediate_values ? r.file.values : std::move(r.file.values);
  if (!options.keep_intermediate_values) r.file.values = Values();
  try {
    r.init = InitializeProblem(r.file.graph, &values, options.init, options.input);
  } catch (const Error& e) {
    return stop(PipelineStatus::kBadInput, e.what());
  }
  r.initialized = true;
  if (options.keep_intermediate_values) r.initial = values;
  if (hooks.on_initialized) hooks.on_initialized(r.init);

  if (options.gnc) {
    r.gnc = OptimizeGnc(r.file.graph, &values, options.gnc_options);
    r.summary = r.gnc.last;
    if (!r.gnc.usable && r.summary.IsSolutionUsable()) {
      r.summary.status = SolverStatus::kDiverged;
      r.summary.message = r.gnc.message;
    }
  } else if (options.switchable) {
    r.switchable = OptimizeSwitchable(r.file.graph, &values, options.switchable_options);
    r.summary = r.switchable.refit.IsSolutionUsable() ? r.switchable.refit : r.switchable.solve;
    if (!r.switchable.usable && r.summary.IsSolutionUsable()) {
      r.summary.status = SolverStatus::kDiverged;
      r.summary.message = r.switchable.message;
    }
  } else {
    r.summary = OptimizeProblem(r.file.graph, &values, options.solver);
  }
  r.optimized = true;
  r.values = std::move(values);
  if (hooks.on_optimized) hooks.on_optimized(r.summary);
  if (!r.summary.IsSolutionUsable()) {
    return stop(PipelineStatus::kSolveFailed, "the solve failed (" + std::string(ToString(r.summary.status)) +
                                                  "): " + r.summary.message + "; no output written");
  }

  if (output != nullptr) {
    try {
      output->Stage([&](std::ostream& s) { WriteG2o(s, r.values, r.file.graph, registry); });
      output->Commit();
    } catch (const Error& e) {
      return stop(PipelineStatus::kWriteFailed, e.what());
    }
    r.written = true;
  }
  r.status = PipelineStatus::kOk;
  return r;
}

}  // namespace tether
