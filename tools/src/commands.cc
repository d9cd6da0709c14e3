#include "tether/tools/commands.h"

#include <chrono>
#include <cstdio>
#include <map>
#include <ostream>
#include <sstream>

#include "svg_writer.h"
#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/core/output_file.h"
#include "tether/factors/builtin.h"
#include "tether/frontends/simulation/simulate.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/solvers/covariance.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/pipeline.h"
#include "tether/tools/svg_plot.h"
#include "tether/tools/trajectory_error.h"

namespace tether {

namespace {

std::string Row(const IterationSummary& it) {
  char buf[200];
  char rel[32], lam[32], step[32];
  if (it.iteration == 0) {
    std::snprintf(rel, sizeof(rel), "%11s", "-");
    std::snprintf(step, sizeof(step), "%10s", "-");
  } else {
    std::snprintf(rel, sizeof(rel), "%11.3e", it.relative_decrease);
    std::snprintf(step, sizeof(step), "%10.3e", it.step_norm);
  }
  if (it.lambda > 0) {
    std::snprintf(lam, sizeof(lam), "%9.2e", it.lambda);
  } else {
    std::snprintf(lam, sizeof(lam), "%9s", "-");
  }
  char reuse[48] = "";
  if (it.reused_factorization) std::snprintf(reuse, sizeof(reuse), "  reused factorisation (%d CG)", it.cg_iterations);
  std::snprintf(buf, sizeof(buf), "%5d  %16.9g  %s  %s  %s  %9.3f%s%s", it.iteration, it.chi2, rel, lam, step,
                it.seconds, it.accepted ? "" : "  rejected", reuse);
  return buf;
}

struct GraphCounts {
  std::size_t poses = 0, landmarks = 0;
};

// Loads the plugins into the default registry; returns false (after saying why) on failure.
bool LoadPlugins(const std::vector<std::string>& plugins, PluginLoader* loader, std::ostream& out, std::ostream& err) {
  for (const std::string& p : plugins) {
    try {
      const LoadedPlugin l = loader->Load(p);
      out << l.Summary() << "\n";
    } catch (const Error& e) {
      err << "error: " << e.what() << "\n";
      return false;
    }
  }
  return true;
}

GraphCounts Count(const Values& v) {
  GraphCounts c;
  c.poses = v.Count(VarType::kSE2) + v.Count(VarType::kSE3);
  c.landmarks = v.Count(VarType::kPoint2) + v.Count(VarType::kPoint3);
  return c;
}

// The one place that turns the command's arguments into SolverOptions (the solver's names and
// fields); returns false after saying why where an argument is not usable.
bool FillSolverOptions(const OptimizeCommand& cmd, SolverOptions* options, std::ostream& err) {
  // A plugin's step strategy or linear solver is known once the plugin is loaded
  // (CheckSolverOptions checks both names then).
  options->algorithm = Algorithm(cmd.solver);
  options->linear_solver = LinearSolverType(cmd.linear);
  if (options->algorithm == Algorithm::kCeres && options->linear_solver != LinearSolverType::kCholmod) {
    err << "tether optimize: --solver ceres solves with Ceres' SPARSE_NORMAL_CHOLESKY over SuiteSparse; use "
           "--linear cholmod (ldlt and qr are for gn and lm)\n";
    return false;
  }
  options->max_iterations = cmd.max_iterations;
  options->max_seconds = cmd.time_limit;
  if (cmd.threads < 1 || cmd.threads > 256) {
    err << "tether optimize: --threads must be between 1 and 256, got " << cmd.threads << "\n";
    return false;
  }
  options->num_threads = cmd.threads;
  options->linear.max_reuse_iterations = cmd.max_reuse_iterations;
  return true;
}

// After the plugins are loaded: the step strategy's and the linear solver's names, then every
// option.
bool CheckSolverOptions(const OptimizeCommand& cmd, SolverOptions* options, std::ostream& err) {
  if (!FromString(cmd.solver, &options->algorithm)) {
    err << "tether optimize: unknown --solver '" << cmd.solver << "'; use " << AlgorithmNames()
        << " (or load the plugin that provides it with --plugin)\n";
    return false;
  }
  if (!FromString(cmd.linear, &options->linear_solver)) {
    err << "tether optimize: unknown --linear '" << cmd.linear << "'; use " << LinearSolverNames()
        << " (or load the plugin that provides it with --plugin)\n";
    return false;
  }
  std::string why;
  if (!options->IsValid(&why)) {
    err << "tether optimize: " << why << "\n";
    return false;
  }
  return true;
}

// The pipeline's options from the command (exit code 2 where the arguments are not usable).
bool FillPipelineOptions(const OptimizeCommand& cmd, PipelineOptions* po, std::ostream& err) {
  po->input = cmd.input;
  po->output = cmd.output;
  if (!FillSolverOptions(cmd, &po->solver, err)) return false;
  if (!FromString(cmd.init, &po->init)) {
    err << "tether optimize: unknown --init '" << cmd.init << "'; use file, spanning-tree or chordal\n";
    return false;
  }
  if (!FromString(cmd.repair_information, &po->read.repair)) {
    err << "tether optimize: unknown --repair-information '" << cmd.repair_information
        << "'; use none, nearest-pd or isotropic\n";
    return false;
  }
  po->read.allow_partial_vertices = cmd.allow_partial_vertices;
  const std::map<std::string, FileFormat> formats = {
      {"auto", FileFormat::kAuto}, {"g2o", FileFormat::kG2o}, {"toro", FileFormat::kToro}, {"isam", FileFormat::kIsam}};
  const auto format = formats.find(cmd.format);
  if (format == formats.end()) {
    err << "tether optimize: unknown --format '" << cmd.format << "'; use auto, g2o, toro or isam\n";
    return false;
  }
  po->read.format = format->second;
  if (cmd.isam_noise == "sqrt-information") {
    po->read.isam_noise = IsamNoise::kSquareRootInformation;
  } else if (cmd.isam_noise == "covariance") {
    po->read.isam_noise = IsamNoise::kCovariance;
  } else {
    err << "tether optimize: unknown --isam-noise '" << cmd.isam_noise << "'; use sqrt-information or covariance\n";
    return false;
  }
  if (cmd.gnc) {
    po->gnc = true;
    po->gnc_options.inner = po->solver;
    if (po->gnc_options.inner.max_iterations > 30) po->gnc_options.inner.max_iterations = 30;
    if (cmd.gnc_kernel == "tls") {
      po->gnc_options.kernel = GncKernel::kTruncatedLeastSquares;
    } else if (cmd.gnc_kernel == "gm") {
      po->gnc_options.kernel = GncKernel::kGemanMcClure;
    } else {
      err << "tether optimize: unknown --gnc-kernel '" << cmd.gnc_kernel << "'; use tls or gm\n";
      return false;
    }
    if (cmd.gnc_start == "chunked") {
      po->gnc_options.start = GncStart::kChunkedDcs;
    } else if (cmd.gnc_start == "least-squares") {
      po->gnc_options.start = GncStart::kLeastSquares;
    } else {
      err << "tether optimize: unknown --gnc-start '" << cmd.gnc_start << "'; use chunked or least-squares\n";
      return false;
    }
  }
  if (cmd.switchable) {
    if (cmd.gnc) {
      err << "tether optimize: --gnc and --switchable are two ways to solve; choose one\n";
      return false;
    }
    po->switchable = true;
    po->switchable_options.solver = po->solver;
    if (po->switchable_options.solver.max_iterations < 100) po->switchable_options.solver.max_iterations = 100;
    po->switchable_options.prior_sigma = cmd.switch_prior_sigma;
    std::string why;
    if (!po->switchable_options.IsValid(&why)) {
      err << "tether optimize: --switch-prior-sigma: " << why << "\n";
      return false;
    }
  } else if (cmd.switch_prior_sigma != 0) {
    err << "tether optimize: --switch-prior-sigma needs --switchable\n";
    return false;
  }
  if (!cmd.gnc && !cmd.switchable && !cmd.rejected_output.empty()) {
    err << "tether optimize: --rejected-out needs --gnc or --switchable\n";
    return false;
  }
  for (const std::string& rule : cmd.robust) {
    try {
      po->robust.push_back(ParseRobustRule(rule));
    } catch (const InvalidArgument& e) {
      err << "tether optimize: --robust: " << e.what() << "\n";
      return false;
    }
  }
  return true;
}

// --gnc, --switchable: the rejected loop closures, counted, and staged as g2o lines into
// `file` where there is one.
void ReportRejected(const OptimizeCommand& cmd, const PipelineResult& result, const Registry& registry,
                    OutputFile* file, std::ostream& out) {
  const bool gnc = cmd.gnc;
  const std::vector<std::size_t>& rejected = gnc ? result.gnc.rejected : result.switchable.rejected;
  const std::vector<double>& weights = gnc ? result.gnc.weights : result.switchable.weights;
  char seconds[32];
  std::snprintf(seconds, sizeof seconds, "%.3f s", gnc ? result.gnc.seconds : result.switchable.seconds);
  if (gnc) {
    char phases[160];
    std::snprintf(phases, sizeof phases, "start %d iterations %.3f s, %d stages %.3f s, %d in doubt, final %.3f s; ",
                  result.gnc.start_iterations, result.gnc.start_seconds, result.gnc.stages, result.gnc.stages_seconds,
                  result.gnc.doubtful, result.gnc.final_seconds);
    out << "gnc (" << cmd.gnc_kernel << ", from " << cmd.gnc_start << "): " << phases;
  } else {
    out << "switchable constraints: ";
  }
  out << rejected.size() << " of " << (gnc ? result.gnc.loop_closures : result.switchable.loop_closures)
      << " loop closures rejected (weight below "
      << (gnc ? GncOptions().reject_below : SwitchableOptions().reject_below) << "), " << seconds << "\n";
  if (file == nullptr) return;
  std::string text;
  for (std::size_t i : rejected) {
    char weight[64];
    std::snprintf(weight, sizeof weight, "# factor %zu, weight %.3g\n", i, weights[i]);
    text += weight;
    try {
      text += registry.Write(result.file.graph.at(i)) + "\n";
    } catch (const Error& e) {
      text += "# (no g2o form: " + std::string(e.what()) + ")\n";
    }
  }
  file->Stage(text);
}

// --covariance: "all", or comma-separated ids into `keys`; false after saying why.
bool ParseCovarianceKeys(const OptimizeCommand& cmd, std::vector<Key>* keys, std::ostream& err) {
  if (cmd.covariance.empty()) return true;
  if (cmd.output.empty() && cmd.covariance_output.empty()) {
    err << "tether optimize: --covariance needs -o OUTPUT (the covariances go to OUTPUT.cov) or --covariance-out\n";
    return false;
  }
  if (cmd.covariance == "all") return true;
  std::stringstream ss(cmd.covariance);
  std::string item;
  while (std::getline(ss, item, ',')) {
    std::size_t used = 0;
    unsigned long long id = 0;
    try {
      id = std::stoull(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (item.empty() || used != item.size() || item[0] == '-') {
      err << "tether optimize: --covariance takes comma-separated variable ids or all; '" << item << "' is not an id\n";
      return false;
    }
    keys->push_back(static_cast<Key>(id));
  }
  return true;
}

// The marginal covariances at the solution, staged into `file`; 0, or 1 after saying why (an
// id that has none, a singular system).
int StageCovariances(const OptimizeCommand& cmd, const PipelineResult& result, std::vector<Key> keys, OutputFile* file,
                     std::ostream& out, std::ostream& err) {
  CovarianceOptions options;
  if (cmd.linear == "ldlt" || cmd.linear == "qr") options.linear_solver = cmd.linear;
  options.num_threads = cmd.threads;
  try {
    using Clock = std::chrono::steady_clock;
    const Clock::time_point t0 = Clock::now();
    const Marginals marginals(result.file.graph, result.values, options);
    const Clock::time_point t1 = Clock::now();
    if (cmd.covariance == "all") keys = marginals.free_keys();
    const std::vector<Eigen::MatrixXd> cov = marginals.MarginalsOf(keys);
    const Clock::time_point t2 = Clock::now();
    file->Stage([&](std::ostream& s) { WriteCovariances(s, result.values, keys, cov); });
    const auto sec = [](Clock::duration d) { return std::chrono::duration<double>(d).count(); };
    char buf[240];
    std::snprintf(buf, sizeof buf,
                  "covariance of %zu variables in %.4f s: linearise %.4f s, factorise %.4f s, marginals %.4f s\n",
                  keys.size(), sec(t2 - t0), marginals.linearize_seconds(), marginals.factorize_seconds(),
                  sec(t2 - t1));
    out << buf << "covariance method: " << marginals.Description() << "\n";
  } catch (const IoError&) {
    throw;
  } catch (const Error& e) {
    err << "error: covariance: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

// Every output of `tether optimize`, checked before anything runs (paths usable, none naming
// an input or another output) and committed together once everything is staged.
struct OptimizeOutputs {
  OutputSet set;
  OutputFile* graph = nullptr;
  OutputFile* plot = nullptr;
  OutputFile* rejected = nullptr;
  OutputFile* covariance = nullptr;
};

// 0, or the exit code after saying why: 2 for an output the arguments cannot have (an empty
// path, two outputs or an input and an output on one file), 4 for a path that cannot be written.
int PrepareOutputs(const OptimizeCommand& cmd, OptimizeOutputs* o, std::ostream& err) {
  return CheckOutputs(
      "optimize", o->set,
      [&] {
        o->set.AddInput(cmd.input, "input graph");
        o->set.AddInput(cmd.ground_truth, "ground truth");
        for (const std::string& p : cmd.plugins) o->set.AddInput(p, "plugin");
        if (!cmd.output.empty()) o->graph = &o->set.Add(cmd.output, "optimised graph");
        if (!cmd.plot.empty()) o->plot = &o->set.Add(cmd.plot, "plot");
        if (cmd.gnc || cmd.switchable) {
          const std::string path = !cmd.rejected_output.empty() ? cmd.rejected_output
                                   : !cmd.output.empty()        ? cmd.output + ".rejected.g2o"
                                                                : "";
          if (!path.empty()) o->rejected = &o->set.Add(path, "rejected loop closures");
        }
        if (!cmd.covariance.empty() && (!cmd.output.empty() || !cmd.covariance_output.empty())) {
          const std::string path = cmd.covariance_output.empty() ? cmd.output + ".cov" : cmd.covariance_output;
          o->covariance = &o->set.Add(path, "covariances");
        }
      },
      err);
}

// Commits every staged output and says so; 0, or kExitWriteFailed after saying why (nothing is
// then written).
int CommitOutputs(OutputSet* set, const std::vector<const OutputFile*>& files, std::ostream& out, std::ostream& err) {
  try {
    set->CommitAll();
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return kExitWriteFailed;
  }
  for (const OutputFile* f : files) {
    if (f != nullptr && f->committed()) out << "wrote " << f->path() << "\n";
  }
  return 0;
}

}  // namespace

int CheckOutputs(const std::string& command, OutputSet& set, const std::function<void()>& add, std::ostream& err) {
  try {
    add();
  } catch (const IoError& e) {
    err << "error: " << e.what() << "\n";
    return kExitWriteFailed;
  } catch (const Error& e) {
    err << "tether " << command << ": " << e.what() << "\n";
    return kExitUsage;
  }
  for (const std::string& note : set.Notes()) err << "note: " << note << "\n";
  return 0;
}

int RunOptimize(const OptimizeCommand& cmd, std::ostream& out, std::ostream& err) {
  PipelineOptions po;
  if (!FillPipelineOptions(cmd, &po, err)) return 2;
  OptimizeOutputs outputs;
  if (const int rc = PrepareOutputs(cmd, &outputs, err); rc != 0) return rc;
  po.output.clear();  // the graph is staged with the other outputs and committed with them
  Registry& registry = DefaultRegistry();
  PluginLoader loader(registry);
  if (!LoadPlugins(cmd.plugins, &loader, out, err)) return kExitPluginFailed;
  if (!CheckSolverOptions(cmd, &po.solver, err)) return 2;
  std::vector<Key> covariance_keys;
  if (!ParseCovarianceKeys(cmd, &covariance_keys, err)) return 2;
  GraphFile truth;
  if (!cmd.ground_truth.empty()) {
    try {
      truth = ReadGraphFile(cmd.ground_truth, registry);
    } catch (const Error& e) {
      err << "error: " << e.what() << "\n";
      return 1;
    }
  }

  PipelineHooks hooks;
  hooks.on_read = [&](const GraphFile& file) {
    for (const std::string& w : file.warnings) err << "warning: " << w << "\n";
    const GraphCounts counts = Count(file.values);
    out << "read " << cmd.input << ": " << counts.poses << " poses, " << counts.landmarks << " landmarks, "
        << file.graph.size() << " factors";
    if (!file.graph.fixed().empty()) out << ", " << file.graph.fixed().size() << " fixed";
    out << "\n";
    if (!po.robust.empty()) {
      std::size_t robust = 0;
      for (const auto& f : file.graph.factors()) robust += f->loss() != nullptr;
      out << "robust losses: " << robust << " of " << file.graph.size() << " factors (" << file.loop_closures
          << " loop closures: edges between non-consecutive poses)\n";
    }
    if (file.initialised_by_spanning_tree > 0) {
      out << "initial values: " << file.initialised_by_spanning_tree
          << " variables composed along a spanning tree from the lowest id\n";
    }
  };
  hooks.on_initialized = [&](const InitSummary& is) {
    if (po.init != InitMethod::kFile) out << is.message << "\n";
    if (!cmd.quiet) out << "iter              chi2    rel.decr     lambda   step norm   time [s]\n";
  };
  hooks.on_optimized = [&](const SolverSummary& summary) { out << summary.FullReport(); };
  if (!cmd.quiet) po.solver.callback = [&out](const IterationSummary& it) { out << Row(it) << std::endl; };

  // The file's start is needed only to draw it or to measure its error.
  po.keep_intermediate_values = !cmd.plot.empty() || !cmd.ground_truth.empty();
  const PipelineResult result = RunPipeline(po, registry, hooks);
  if (!result.ok()) {
    err << "error: " << result.message << "\n";
    return result.ExitCode();
  }
  // Every output is staged first; a failure on the way leaves every target as it was.
  try {
    if (outputs.graph != nullptr) {
      outputs.graph->Stage([&](std::ostream& s) { WriteG2o(s, result.values, result.file.graph, registry); });
    }
    if (cmd.gnc || cmd.switchable) ReportRejected(cmd, result, registry, outputs.rejected, out);
    if (outputs.covariance != nullptr) {
      const int rc = StageCovariances(cmd, result, covariance_keys, outputs.covariance, out, err);
      if (rc != 0) return rc;
    }
  } catch (const Error& e) {
    err << "error: " << e.what() << "; nothing was written\n";
    return kExitWriteFailed;
  }
  if (!cmd.ground_truth.empty()) {
    const TrajectoryError start = AbsoluteTrajectoryError(result.file.values, truth.values);
    const TrajectoryError end = AbsoluteTrajectoryError(result.values, truth.values);
    if (end.poses == 0) {
      err << "warning: " << cmd.ground_truth << " has no pose of " << cmd.input << "; no absolute trajectory error\n";
    } else {
      out << "absolute trajectory error against " << cmd.ground_truth << " (" << end.poses
          << " poses, after a rigid alignment): start " << FormatMetres(start.rmse) << ", result "
          << FormatMetres(end.rmse) << "\n";
    }
  }
  try {
    if (outputs.plot != nullptr) {
      PlotOptions plot;
      plot.title = cmd.input;
      plot.before_label = "file's start";
      plot.after_label = "result";
      const Values* gt = cmd.ground_truth.empty() ? nullptr : &truth.values;
      outputs.plot->Stage(RenderSvg(result.file.graph, &result.file.values, &result.values, gt, plot));
    }
  } catch (const Error& e) {
    err << "error: " << e.what() << "; nothing was written\n";
    return kExitWriteFailed;
  }
  return CommitOutputs(&outputs.set, {outputs.graph, outputs.rejected, outputs.covariance, outputs.plot}, out, err);
}

int RunSimulate(const SimulateCommand& cmd, std::ostream& out, std::ostream& err) {
  SimulateOptions so;
  if (!FromString(cmd.world, &so.world)) {
    err << "tether simulate: unknown world '" << cmd.world << "'; use manhattan, sphere or landmarks\n";
    return 2;
  }
  so.poses = cmd.poses;
  so.seed = cmd.seed;
  std::string why;
  if (!so.IsValid(&why)) {
    err << "tether simulate: " << why << "\n";
    return 2;
  }
  if (cmd.output.empty()) {
    err << "tether simulate: -o FILE is required\n";
    return 2;
  }
  OutputSet outputs;
  OutputFile* graph_file = nullptr;
  OutputFile* truth_file = nullptr;
  const int rc = CheckOutputs(
      "simulate", outputs,
      [&] {
        graph_file = &outputs.Add(cmd.output, "simulated graph");
        if (!cmd.ground_truth.empty()) truth_file = &outputs.Add(cmd.ground_truth, "ground truth");
      },
      err);
  if (rc != 0) return rc;
  const SimulatedGraph sim = Simulate(so);
  try {
    graph_file->Stage([&](std::ostream& s) { WriteG2o(s, sim.initial, sim.graph, DefaultRegistry()); });
    if (truth_file != nullptr) {
      truth_file->Stage([&](std::ostream& s) { WriteG2o(s, sim.ground_truth, sim.graph, DefaultRegistry()); });
    }
  } catch (const Error& e) {
    err << "error: " << e.what() << "; nothing was written\n";
    return kExitWriteFailed;
  }
  try {
    outputs.CommitAll();  // its message says what became of the files
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return kExitWriteFailed;
  }
  const GraphCounts counts = Count(sim.ground_truth);
  out << "wrote " << cmd.output << ": " << cmd.world << ", " << counts.poses << " poses, " << counts.landmarks
      << " landmarks, " << sim.graph.size() << " factors (" << sim.odometry_factors << " odometry, "
      << sim.loop_closures << " loop closures, " << sim.observations << " observations), seed " << cmd.seed << "\n";
  if (!cmd.ground_truth.empty()) out << "wrote ground truth " << cmd.ground_truth << "\n";
  return 0;
}

int RunPluginsList(const PluginsListCommand& cmd, std::ostream& out, std::ostream& err) {
  Registry& registry = DefaultRegistry();
  PluginLoader loader(registry);
  if (!LoadPlugins(cmd.plugins, &loader, out, err)) return kExitPluginFailed;
  out << "plugin search path (after explicit paths):";
  for (const std::string& d : PluginLoader::SearchPath()) out << " " << d;
  out << "\n";
  char line[256];
  std::snprintf(line, sizeof(line), "%-20s %-24s %-22s %s\n", "variable type", "g2o vertex tag", "ambient/tangent",
                "owner");
  out << line;
  for (const auto& [name, id] : registry.variable_types()) {
    const VariableType& d = Describe(id);
    const std::string sizes = std::to_string(d.ambient_dim) + "/" + std::to_string(d.tangent_dim);
    std::snprintf(line, sizeof(line), "%-20s %-24s %-22s %s\n", name.c_str(), d.tag.empty() ? "(none)" : d.tag.c_str(),
                  sizes.c_str(), registry.VariableOwner(name).c_str());
    out << line;
  }
  out << "\n";
  std::snprintf(line, sizeof(line), "%-20s %-24s %4s  %-20s %s\n", "factor type", "g2o tag", "dim", "variables",
                "owner");
  out << line;
  for (const auto& [name, t] : registry.types()) {
    std::string vars;
    for (VarType v : t.variable_types) vars += (vars.empty() ? "" : " ") + std::string(ToString(v));
    std::snprintf(line, sizeof(line), "%-20s %-24s %4d  %-20s %s\n", name.c_str(),
                  t.tag.empty() ? "(none)" : t.tag.c_str(), t.dim, vars.c_str(), t.owner.c_str());
    out << line;
  }
  return 0;
}

}  // namespace tether
