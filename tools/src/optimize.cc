// `tether optimize`: read a graph file, initialise, optimise, write; the pipeline does the work
// (tether/solvers/pipeline.h), this file binds the flags to its options and prints its report.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ostream>
#include <sstream>
#include <streambuf>
#include <string>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/core/loss_registry.h"
#include "tether/core/output_file.h"
#include "tether/core/svg_plot.h"
#include "tether/core/trajectory_error.h"
#include "tether/factors/builtin.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/solvers/covariance.h"
#include "tether/solvers/distributed.h"
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

// The pipeline's fields its messages name, with the flags that set them.
constexpr std::pair<const char*, const char*> kFieldFlags[] = {
    {"output", "-o"},
    {"rejected_output", "--rejected-out"},
    {"covariance", "--covariance"},
    {"covariance_output", "--covariance-out"},
    {"gnc", "--gnc"},
    {"switchable", "--switchable"},
};

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
    err << "tether optimize: " << WithFlags(why, kFieldFlags) << "\n";
    return false;
  }
  return true;
}

// --gnc, --switchable: the rejected loop closures, counted.
void ReportRejected(const PipelineOptions& po, const PipelineResult& result, std::ostream& out) {
  const bool gnc = po.gnc;
  const std::vector<std::size_t>& rejected = gnc ? result.gnc.rejected : result.switchable.rejected;
  char seconds[32];
  std::snprintf(seconds, sizeof seconds, "%.3f s", gnc ? result.gnc.seconds : result.switchable.seconds);
  if (gnc) {
    char phases[160];
    std::snprintf(phases, sizeof phases, "start %d iterations %.3f s, %d stages %.3f s, %d in doubt, final %.3f s; ",
                  result.gnc.start_iterations, result.gnc.start_seconds, result.gnc.stages, result.gnc.stages_seconds,
                  result.gnc.doubtful, result.gnc.final_seconds);
    out << "gnc (" << po.gnc_options.kernel << ", from " << po.gnc_options.start << "): " << phases;
  } else {
    out << "switchable constraints: ";
  }
  out << rejected.size() << " of " << (gnc ? result.gnc.loop_closures : result.switchable.loop_closures)
      << " loop closures rejected (weight below "
      << (gnc ? GncOptions().reject_below : SwitchableOptions().reject_below) << "), " << seconds << "\n";
}

// --covariance: "all", or comma-separated ids into the pipeline's keys; false after saying why.
bool ParseCovarianceKeys(const std::string& text, PipelineOptions* po, std::ostream& err) {
  po->covariance = !text.empty();
  if (text.empty() || text == "all") return true;
  std::stringstream ss(text);
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
    po->covariance_keys.push_back(static_cast<Key>(id));
  }
  return true;
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

// What the pipeline computed after the solve, and the files it wrote.
void PrintResult(const PipelineOptions& po, const PipelineResult& result, std::ostream& out, std::ostream& err) {
  if (!result.optimized || !result.summary.IsSolutionUsable()) return;
  if (po.gnc || po.switchable) ReportRejected(po, result, out);
  const PipelineCovariances& c = result.covariances;
  if (!c.method.empty()) {
    char buf[240];
    std::snprintf(buf, sizeof buf,
                  "covariance of %zu variables in %.4f s: linearise %.4f s, factorise %.4f s, marginals %.4f s\n",
                  c.keys.size(), c.seconds, c.linearize_seconds, c.factorize_seconds, c.marginals_seconds);
    out << buf << "covariance method: " << c.method << "\n";
  }
  if (!po.ground_truth.empty() && result.result_error.poses == 0) {
    err << "warning: " << po.ground_truth << " has no pose of " << po.input << "; no absolute trajectory error\n";
  } else if (!po.ground_truth.empty()) {
    out << "absolute trajectory error against " << po.ground_truth << " (" << result.result_error.poses
        << " poses, after a rigid alignment): start " << FormatMetres(result.start_error.rmse) << ", result "
        << FormatMetres(result.result_error.rmse) << "\n";
  }
  for (const std::string& path : result.written_paths) out << "wrote " << path << "\n";
}

// Where the whole process's time went: the start-up before main (CPU time of the main thread:
// loading the libraries), the pipeline's stages, and the rest since main (parsing the flags,
// checking the outputs, printing). The exit after it is not counted.
std::string WholeProcessLine(const PipelineTimes& t) {
  const double startup = std::max(0.0, StartupSeconds());
  const double since_main = SecondsSinceMain();
  const double other = std::max(0.0, since_main - t.Total());
  char buf[320];
  int n =
      std::snprintf(buf, sizeof buf, "whole process %.3f s: start-up %.3f, read %.3f, initialise %.3f, optimise %.3f",
                    startup + since_main, startup, t.read, t.initialize, t.optimize);
  if (t.covariance > 0) n += std::snprintf(buf + n, sizeof buf - n, ", covariance %.3f", t.covariance);
  std::snprintf(buf + n, sizeof buf - n, ", write %.3f, other %.3f\n", t.write, other);
  return buf;
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

namespace {

// Under --linear petsc (or petsc-iterative) every process of the MPI job runs the whole
// command; the first one prints and writes, the others only say what went wrong, prefixed
// with their place. Without those solvers, one process: {0, 1}.
bool StartProcesses(const OptimizeCommand& cmd, DistributedProcess* process, std::ostream& err) {
  const bool distributed = cmd.linear == "petsc" || cmd.linear == "petsc-iterative";
  if (!distributed) {
    // Started by mpirun (or srun) as one of several processes: each would solve alone and
    // write the same outputs.
    for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"}) {
      const char* v = std::getenv(name);
      if (v != nullptr && std::atoi(v) > 1) {
        err << "tether optimize: started as one of " << v << " processes (" << name << ") with --linear " << cmd.linear
            << ", which solves in one: add --linear petsc to solve across them (docs/distributed.md), "
            << "or run one process\n";
        return false;
      }
    }
    if (cmd.petsc_options.empty()) return true;
    err << "tether optimize: --petsc-options needs --linear petsc or petsc-iterative\n";
    return false;
  }
  try {
    *process = StartDistributed(cmd.petsc_options);
  } catch (const Error& e) {
    err << "tether optimize: --linear " << cmd.linear << ": " << e.what() << "\n";
    return false;
  }
  return true;
}

// What the other processes do not write (nor compute only to write: the covariances).
void WriteOnFirstProcessOnly(OptimizeCommand* cmd) {
  cmd->covariance.clear();
  PipelineOptions* po = &cmd->pipeline;
  po->output.clear();
  po->plot_output.clear();
  po->covariance = false;
  po->covariance_output.clear();
  po->rejected_output.clear();
}

class NullBuffer : public std::streambuf {
 protected:
  int overflow(int c) override { return c == traits_type::eof() ? 0 : c; }
};

// Every line `err` receives, prefixed with "[process R] ".
class PrefixBuffer : public std::streambuf {
 public:
  PrefixBuffer(std::ostream& to, int rank) : to_(to), prefix_("[process " + std::to_string(rank) + "] ") {}

 protected:
  int overflow(int c) override {
    if (c == traits_type::eof()) return 0;
    if (at_line_start_) to_ << prefix_;
    to_.put(static_cast<char>(c));
    at_line_start_ = c == '\n';
    return c;
  }

 private:
  std::ostream& to_;
  std::string prefix_;
  bool at_line_start_ = true;
};

int RunOptimizeProcess(const OptimizeCommand& cmd, std::ostream& out, std::ostream& err);

}  // namespace

int RunOptimize(const OptimizeCommand& cmd, std::ostream& out, std::ostream& err) {
  DistributedProcess process;
  if (!StartProcesses(cmd, &process, err)) return kExitUsage;
  int code = 0;
  if (process.rank == 0) {
    code = RunOptimizeProcess(cmd, out, err);
  } else {
    OptimizeCommand mine = cmd;
    WriteOnFirstProcessOnly(&mine);
    NullBuffer null;
    PrefixBuffer prefixed(err, process.rank);
    std::ostream quiet(&null), errors(&prefixed);
    code = RunOptimizeProcess(mine, quiet, errors);
    errors.flush();
  }
  // A process that fails ends the job: the others may be waiting for it in the solve.
  if (code != kExitOk) {
    err.flush();
    AbortDistributed(code);
  }
  return code;
}

namespace {

int RunOptimizeProcess(const OptimizeCommand& cmd, std::ostream& out, std::ostream& err) {
  PipelineOptions po = cmd.pipeline;
  po.other_inputs = cmd.plugins;  // an output may not name a plugin it loads
  PluginLoader loader(DefaultRegistry());
  if (!LoadPlugins(cmd.plugins, &loader, out, err)) return kExitPluginFailed;
  if (!ParseCovarianceKeys(cmd.covariance, &po, err)) return kExitUsage;
  if (!ResolveOptions(cmd, &po, err)) return kExitUsage;
  const PipelineHooks hooks = PrintingHooks(cmd, &po, out, err);
  po.plot.before_label = "file's start";
  po.plot.after_label = "result";
  const PipelineResult result = RunPipeline(po, DefaultRegistry(), hooks);
  for (const std::string& note : result.output_notes) err << "note: " << note << "\n";
  PrintResult(po, result, out, err);
  if (result.optimized) out << WholeProcessLine(result.times);
  if (!result.ok()) err << "error: " << result.message << "\n";
  return ExitCodeOf(result.status);
}

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
  sub->add_option("--linear", cmd_.linear,
                  "auto (block Cholesky on sparse factors, CHOLMOD on dense ones) | block | cholmod | ldlt | qr | "
                  "petsc, petsc-iterative (over the processes of an MPI job: mpirun -np K tether optimize ...; "
                  "docs/distributed.md) | a plugin's linear solver (pcg)")
      ->capture_default_str();
  sub->add_option("--petsc-options", cmd_.petsc_options,
                  "With --linear petsc or petsc-iterative: PETSc's options, as on its command line (\"-ksp_type cg "
                  "-pc_type bjacobi\", \"-mat_mumps_icntl_14 50\")");
  sub->add_option("--covariance", cmd_.covariance,
                  "After the solve, marginal covariances of these ids (comma-separated) or of all");
  AddPath(sub, "--covariance-out", &po.covariance_output, "Covariance file (default: OUTPUT.cov)")
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
  AddPath(sub, "--plot", &po.plot_output, "Write an SVG of the file's start and the result (and the ground truth)");
  AddPath(sub, "--ground-truth", &po.ground_truth,
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
  AddPath(sub, "--rejected-out", &po.rejected_output,
          "With --gnc or --switchable: write the rejected loop closures here (default: OUTPUT.rejected.g2o)");
}

}  // namespace

std::unique_ptr<Command> MakeOptimizeCommand() { return std::make_unique<OptimizeCli>(); }

}  // namespace tether
