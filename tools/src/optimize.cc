// `tether optimize`: read a graph file, initialise, optimise, write; the pipeline does the work
// (tether/solvers/pipeline.h), this file binds the flags to its options and prints its report.
#include <chrono>
#include <cstdio>
#include <ostream>
#include <sstream>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/core/loss_registry.h"
#include "tether/core/output_file.h"
#include "tether/core/svg_plot.h"
#include "tether/core/trajectory_error.h"
#include "tether/factors/builtin.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/solvers/covariance.h"
#include "tether/tools/commands.h"

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

GraphCounts Count(const Values& v) {
  GraphCounts c;
  c.poses = v.Count(VarType::kSE2) + v.Count(VarType::kSE3);
  c.landmarks = v.Count(VarType::kPoint2) + v.Count(VarType::kPoint3);
  return c;
}

// The step strategy's and the linear solver's names (a plugin's are known once it is loaded),
// the robust rules (a plugin's loss likewise) and the rules between the solve's options, checked
// once, by PipelineOptions::IsValid; false after saying why.
bool ResolveOptions(const OptimizeCommand& cmd, PipelineOptions* po, std::ostream& err) {
  if (!FromString(cmd.solver, &po->solver.algorithm)) {
    err << "tether optimize: unknown --solver '" << cmd.solver << "'; use " << AlgorithmNames()
        << " (or load the plugin that provides it with --plugin)\n";
    return false;
  }
  if (!FromString(cmd.linear, &po->solver.linear_solver)) {
    err << "tether optimize: unknown --linear '" << cmd.linear << "'; use " << LinearSolverNames()
        << " (or load the plugin that provides it with --plugin)\n";
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
  if (po->gnc) po->gnc_options.SetSolver(po->solver);
  if (po->switchable) po->switchable_options.SetSolver(po->solver);
  std::string why;
  if (!po->IsValid(&why)) {
    err << "tether optimize: " << why << "\n";
    return false;
  }
  return true;
}

// --gnc, --switchable: the rejected loop closures, counted, and staged as g2o lines into
// `file` where there is one.
void ReportRejected(const OptimizeCommand& cmd, const PipelineResult& result, const Registry& registry,
                    OutputFile* file, std::ostream& out) {
  const bool gnc = cmd.pipeline.gnc;
  const std::vector<std::size_t>& rejected = gnc ? result.gnc.rejected : result.switchable.rejected;
  const std::vector<double>& weights = gnc ? result.gnc.weights : result.switchable.weights;
  char seconds[32];
  std::snprintf(seconds, sizeof seconds, "%.3f s", gnc ? result.gnc.seconds : result.switchable.seconds);
  if (gnc) {
    char phases[160];
    std::snprintf(phases, sizeof phases, "start %d iterations %.3f s, %d stages %.3f s, %d in doubt, final %.3f s; ",
                  result.gnc.start_iterations, result.gnc.start_seconds, result.gnc.stages, result.gnc.stages_seconds,
                  result.gnc.doubtful, result.gnc.final_seconds);
    out << "gnc (" << cmd.pipeline.gnc_options.kernel << ", from " << cmd.pipeline.gnc_options.start << "): " << phases;
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
  if (cmd.pipeline.output.empty() && cmd.covariance_output.empty()) {
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
  options.num_threads = cmd.pipeline.solver.num_threads;
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
        o->set.AddInput(cmd.pipeline.input, "input graph");
        o->set.AddInput(cmd.ground_truth, "ground truth");
        for (const std::string& p : cmd.plugins) o->set.AddInput(p, "plugin");
        if (!cmd.pipeline.output.empty()) o->graph = &o->set.Add(cmd.pipeline.output, "optimised graph");
        if (!cmd.plot.empty()) o->plot = &o->set.Add(cmd.plot, "plot");
        if (cmd.pipeline.gnc || cmd.pipeline.switchable) {
          const std::string path = !cmd.rejected_output.empty()   ? cmd.rejected_output
                                   : !cmd.pipeline.output.empty() ? cmd.pipeline.output + ".rejected.g2o"
                                                                  : "";
          if (!path.empty()) o->rejected = &o->set.Add(path, "rejected loop closures");
        }
        if (!cmd.covariance.empty() && (!cmd.pipeline.output.empty() || !cmd.covariance_output.empty())) {
          const std::string path = cmd.covariance_output.empty() ? cmd.pipeline.output + ".cov" : cmd.covariance_output;
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

// The lines printed between the pipeline's stages, and the iteration table.
PipelineHooks PrintingHooks(const OptimizeCommand& cmd, PipelineOptions* po, std::ostream& out, std::ostream& err) {
  PipelineHooks hooks;
  hooks.on_read = [&cmd, po, &out, &err](const GraphFile& file) {
    for (const std::string& w : file.warnings) err << "warning: " << w << "\n";
    const GraphCounts counts = Count(file.values);
    out << "read " << cmd.pipeline.input << ": " << counts.poses << " poses, " << counts.landmarks << " landmarks, "
        << file.graph.size() << " factors";
    if (!file.graph.fixed().empty()) out << ", " << file.graph.fixed().size() << " fixed";
    out << "\n";
    if (!po->robust.empty()) {
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
  hooks.on_initialized = [&cmd, po, &out](const InitSummary& is) {
    if (po->init != InitMethod::kFile) out << is.message << "\n";
    if (!cmd.quiet) out << "iter              chi2    rel.decr     lambda   step norm   time [s]\n";
  };
  hooks.on_optimized = [&out](const SolverSummary& summary) { out << summary.FullReport(); };
  if (!cmd.quiet) {
    const auto row = [&out](const IterationSummary& it) { out << Row(it) << std::endl; };
    po->solver.callback = row;
  }
  return hooks;
}

// The absolute trajectory error of the file's start and of the result against the truth.
void ReportTrajectoryError(const OptimizeCommand& cmd, const PipelineResult& result, const Values& truth,
                           std::ostream& out, std::ostream& err) {
  const TrajectoryError start = AbsoluteTrajectoryError(result.file.values, truth);
  const TrajectoryError end = AbsoluteTrajectoryError(result.values, truth);
  if (end.poses == 0) {
    err << "warning: " << cmd.ground_truth << " has no pose of " << cmd.pipeline.input
        << "; no absolute trajectory error\n";
    return;
  }
  out << "absolute trajectory error against " << cmd.ground_truth << " (" << end.poses
      << " poses, after a rigid alignment): start " << FormatMetres(start.rmse) << ", result " << FormatMetres(end.rmse)
      << "\n";
}

// Stages every output of a successful run; 0, or the exit code after saying why (nothing is
// then written).
int StageOutputs(const OptimizeCommand& cmd, const PipelineResult& result, const std::vector<Key>& covariance_keys,
                 const Values* truth, OptimizeOutputs* outputs, std::ostream& out, std::ostream& err) {
  const Registry& registry = DefaultRegistry();
  try {
    if (outputs->graph != nullptr) {
      outputs->graph->Stage([&](std::ostream& s) { WriteG2o(s, result.values, result.file.graph, registry); });
    }
    if (cmd.pipeline.gnc || cmd.pipeline.switchable) ReportRejected(cmd, result, registry, outputs->rejected, out);
    if (outputs->covariance != nullptr) {
      const int rc = StageCovariances(cmd, result, covariance_keys, outputs->covariance, out, err);
      if (rc != 0) return rc;
    }
    if (truth != nullptr) ReportTrajectoryError(cmd, result, *truth, out, err);
    if (outputs->plot != nullptr) {
      PlotOptions plot;
      plot.title = cmd.pipeline.input;
      plot.before_label = "file's start";
      plot.after_label = "result";
      outputs->plot->Stage(RenderSvg(result.file.graph, &result.file.values, &result.values, truth, plot));
    }
  } catch (const Error& e) {
    err << "error: " << e.what() << "; nothing was written\n";
    return kExitWriteFailed;
  }
  return kExitOk;
}

}  // namespace

int ExitCodeOf(PipelineStatus status) {
  switch (status) {
    case PipelineStatus::kOk:
      return kExitOk;
    case PipelineStatus::kInvalidOptions:
      return kExitUsage;
    case PipelineStatus::kSolveFailed:
      return kExitSolveFailed;
    case PipelineStatus::kWriteFailed:
      return kExitWriteFailed;
    case PipelineStatus::kBadInput:
      break;
  }
  return kExitBadInput;
}

int RunOptimize(const OptimizeCommand& cmd, std::ostream& out, std::ostream& err) {
  PipelineOptions po = cmd.pipeline;
  if (!po.gnc && !po.switchable && !cmd.rejected_output.empty()) {
    err << "tether optimize: --rejected-out needs --gnc or --switchable\n";
    return kExitUsage;
  }
  OptimizeOutputs outputs;
  if (const int rc = PrepareOutputs(cmd, &outputs, err); rc != 0) return rc;
  po.output.clear();  // the graph is staged with the other outputs and committed with them
  PluginLoader loader(DefaultRegistry());
  if (!LoadPlugins(cmd.plugins, &loader, out, err)) return kExitPluginFailed;
  if (!ResolveOptions(cmd, &po, err)) return kExitUsage;
  std::vector<Key> covariance_keys;
  if (!ParseCovarianceKeys(cmd, &covariance_keys, err)) return kExitUsage;
  GraphFile truth;
  if (!cmd.ground_truth.empty()) {
    try {
      truth = ReadGraphFile(cmd.ground_truth, DefaultRegistry());
    } catch (const Error& e) {
      err << "error: " << e.what() << "\n";
      return kExitBadInput;
    }
  }
  const PipelineHooks hooks = PrintingHooks(cmd, &po, out, err);
  // The file's start is needed only to draw it or to measure its error.
  po.keep_intermediate_values = !cmd.plot.empty() || !cmd.ground_truth.empty();
  const PipelineResult result = RunPipeline(po, DefaultRegistry(), hooks);
  if (!result.ok()) {
    err << "error: " << result.message << "\n";
    return ExitCodeOf(result.status);
  }
  const Values* gt = cmd.ground_truth.empty() ? nullptr : &truth.values;
  if (const int rc = StageOutputs(cmd, result, covariance_keys, gt, &outputs, out, err); rc != 0) return rc;
  return CommitOutputs(&outputs.set, {outputs.graph, outputs.rejected, outputs.covariance, outputs.plot}, out, err);
}

namespace {

class OptimizeCli : public Command {
 public:
  void Add(CLI::App& app) override;
  int Run(std::ostream& out, std::ostream& err) override { return RunOptimize(cmd_, out, err); }

 private:
  void AddRobustOptions(CLI::App* sub);
  OptimizeCommand cmd_;
};

void OptimizeCli::Add(CLI::App& app) {
  CLI::App* sub = app_ = app.add_subcommand("optimize", "Optimise a g2o or TORO graph file");
  PipelineOptions& po = cmd_.pipeline;
  SolverOptions& so = po.solver;
  sub->add_option("input", po.input, "Graph file (.g2o, TORO .graph, or iSAM landmark text; see --format)")->required();
  AddPath(sub, "-o,--output", &po.output, "Write the optimised graph (g2o)");
  sub->add_option("--solver", cmd_.solver, "gn | lm | dogleg | ceres (Ceres' Levenberg-Marquardt)")
      ->capture_default_str();
  sub->add_option("--linear", cmd_.linear, "cholmod | ldlt | qr | a plugin's linear solver (pcg)")
      ->capture_default_str();
  sub->add_option("--covariance", cmd_.covariance,
                  "After the solve, marginal covariances of these ids (comma-separated) or of all");
  AddPath(sub, "--covariance-out", &cmd_.covariance_output, "Covariance file (default: OUTPUT.cov)")
      ->needs("--covariance");
  AddEnumOption(sub, "--init", &po.init, "The initial guess");
  sub->add_option("--max-iterations", so.max_iterations, "Iteration limit")->capture_default_str();
  sub->add_option("--time-limit", so.max_seconds, "Seconds (0: none)")->capture_default_str();
  sub->add_option("--threads", so.num_threads, "Threads assembling the normal equations (1 to 256)")
      ->capture_default_str();
  sub->add_option("--max-reuse-iterations", so.linear.max_reuse_iterations,
                  "Conjugate-gradient iterations a step may take with an earlier factorisation before H is "
                  "factorised afresh (0: factorise every step)")
      ->capture_default_str();
  AddEnumOption(sub, "--format", &po.read.format,
                "By name and content (auto), or g2o, toro, isam (iSAM's ODOMETRY/EDGE2/LANDMARK lines; "
                "docs/landmarks.md)");
  AddEnumOption(sub, "--isam-noise", &po.read.isam_noise,
                "iSAM files: sqrt-information (iSAM's reading of the numbers) or covariance (GTSAM's)");
  AddEnumOption(sub, "--repair-information", &po.read.repair,
                "What to do with information matrices that are not positive definite");
  AddPath(sub, "--plot", &cmd_.plot, "Write an SVG of the file's start and the result (and the ground truth)");
  AddPath(sub, "--ground-truth", &cmd_.ground_truth,
          "g2o file with the true values: report the absolute trajectory error of the start and the result, and "
          "draw the truth in --plot");
  sub->add_flag("-q,--quiet", cmd_.quiet, "No iteration table");
  sub->add_option("--plugin", cmd_.plugins,
                  "Load a plugin (factor types, losses, linear solvers; .so path or name) first; repeatable")
      ->allow_extra_args(false);
  sub->add_flag("--allow-partial-vertices", po.read.allow_partial_vertices,
                "Give vertices without a VERTEX line initial values composed from edges");
  AddRobustOptions(sub);
}

void OptimizeCli::AddRobustOptions(CLI::App* sub) {
  PipelineOptions& po = cmd_.pipeline;
  sub->add_option("--robust", cmd_.robust,
                  "Robust loss rule SELECTOR=LOSS:SCALE: loop=huber:1.0 (edges between non-consecutive poses), "
                  "all=cauchy:2, or a g2o tag (EDGE_SE2=dcs:1); losses " +
                      RegisteredLossesText() + ", more from --plugin; repeatable")
      ->allow_extra_args(false);
  CLI::Option* gnc = sub->add_flag("--gnc", po.gnc,
                                   "Graduated non-convexity on the loop closures (edges between non-consecutive "
                                   "poses); reports the closures it rejects");
  AddEnumOption(sub, "--gnc-kernel", &po.gnc_options.kernel,
                "With --gnc: gm (Geman-McClure) or tls (truncated least squares)")
      ->needs(gnc);
  AddEnumOption(sub, "--gnc-start", &po.gnc_options.start,
                "With --gnc: chunked (DCS solved chunk by chunk in id order) or least-squares (the classic start)")
      ->needs(gnc);
  CLI::Option* switchable =
      sub->add_flag("--switchable", po.switchable,
                    "Switchable constraints on the loop closures (a switch variable per closure with a prior); "
                    "reports the closures it switches off");
  sub->add_option("--switch-prior-sigma", po.switchable_options.prior_sigma,
                  "With --switchable: the switch prior's sigma (0: from the chi2 0.99 quantile of the closure's "
                  "dimension; 1 is Sünderhauf's)")
      ->capture_default_str()
      ->needs(switchable);
  AddPath(sub, "--rejected-out", &cmd_.rejected_output,
          "With --gnc or --switchable: write the rejected loop closures here (default: OUTPUT.rejected.g2o)");
}

}  // namespace

std::unique_ptr<Command> MakeOptimizeCommand() { return std::make_unique<OptimizeCli>(); }

}  // namespace tether
