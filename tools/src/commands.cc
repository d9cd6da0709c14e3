#include "tether/tools/commands.h"

#include <cstdio>
#include <ostream>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/optimizer.h"
#include "tether/tools/simulate.h"
#include "tether/tools/svg_plot.h"

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
      const std::size_t n = l.type_names.size();
      const std::size_t k = l.linear_solver_names.size();
      out << "loaded plugin " << l.name << " " << l.version << " from " << l.path << " (" << n
          << (n == 1 ? " factor type" : " factor types");
      if (k > 0) out << ", " << k << (k == 1 ? " linear solver" : " linear solvers");
      out << ")\n";
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

}  // namespace

int RunOptimize(const OptimizeCommand& cmd, std::ostream& out, std::ostream& err) {
  SolverOptions options;
  InformationRepair repair;
  if (!FromString(cmd.solver, &options.algorithm)) {
    err << "tether optimize: unknown --solver '" << cmd.solver << "'; use " << AlgorithmNames() << "\n";
    return 2;
  }
  // A plugin's linear solver is known once the plugin is loaded (below).
  options.linear_solver = LinearSolverType(cmd.linear);
  if (options.algorithm == Algorithm::kCeres && options.linear_solver != LinearSolverType::kCholmod) {
    err << "tether optimize: --solver ceres solves with Ceres' SPARSE_NORMAL_CHOLESKY over SuiteSparse; use "
           "--linear cholmod (ldlt and qr are for gn and lm)\n";
    return 2;
  }
  InitMethod init;
  if (!FromString(cmd.init, &init)) {
    err << "tether optimize: unknown --init '" << cmd.init << "'; use file, spanning-tree or chordal\n";
    return 2;
  }
  if (!FromString(cmd.repair_information, &repair)) {
    err << "tether optimize: unknown --repair-information '" << cmd.repair_information
        << "'; use none, nearest-pd or isotropic\n";
    return 2;
  }
  options.max_iterations = cmd.max_iterations;
  options.max_seconds = cmd.time_limit;
  if (cmd.threads < 1 || cmd.threads > 256) {
    err << "tether optimize: --threads must be between 1 and 256, got " << cmd.threads << "\n";
    return 2;
  }
  options.num_threads = cmd.threads;
  options.linear.max_reuse_iterations = cmd.max_reuse_iterations;
  Registry& registry = DefaultRegistry();
  PluginLoader loader(registry);
  if (!LoadPlugins(cmd.plugins, &loader, out, err)) return 1;
  if (!FromString(cmd.linear, &options.linear_solver)) {
    err << "tether optimize: unknown --linear '" << cmd.linear << "'; use " << LinearSolverNames()
        << " (or load the plugin that provides it with --plugin)\n";
    return 2;
  }
  std::string why;
  if (!options.IsValid(&why)) {
    err << "tether optimize: " << why << "\n";
    return 2;
  }
  GraphFile file;
  try {
    ReadOptions ro;
    ro.repair = repair;
    ro.allow_partial_vertices = cmd.allow_partial_vertices;
    file = ReadGraphFile(cmd.input, registry, ro);
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return 1;
  }
  for (const std::string& w : file.warnings) err << "warning: " << w << "\n";
  const GraphCounts counts = Count(file.values);
  out << "read " << cmd.input << ": " << counts.poses << " poses, " << counts.landmarks << " landmarks, "
      << file.graph.size() << " factors";
  if (!file.graph.fixed().empty()) out << ", " << file.graph.fixed().size() << " fixed";
  out << "\n";
  if (file.initialised_by_spanning_tree > 0) {
    out << "initial values: " << file.initialised_by_spanning_tree
        << " variables composed along a spanning tree from the lowest id\n";
  }
  try {
    const InitSummary is = Initialize(file.graph, &file.values, init);
    if (init != InitMethod::kFile) out << is.message << "\n";
  } catch (const Error& e) {
    err << "error: " << cmd.input << ": " << e.what() << "\n";
    return 1;
  }
  const Values before = file.values;  // where the solve starts
  if (!cmd.quiet) {
    out << "iter              chi2    rel.decr     lambda   step norm   time [s]\n";
    options.callback = [&out](const IterationSummary& it) { out << Row(it) << std::endl; };
  }
  const SolverSummary summary = Optimize(file.graph, &file.values, options);
  out << summary.FullReport();
  if (!summary.IsSolutionUsable()) {
    err << "error: the solve failed (" << ToString(summary.status) << "): " << summary.message
        << "; no output written\n";
    return 3;
  }
  try {
    if (!cmd.output.empty()) {
      WriteG2oFile(cmd.output, file.values, file.graph, registry);
      out << "wrote " << cmd.output << "\n";
    }
    if (!cmd.plot.empty()) {
      PlotOptions po;
      po.title = cmd.input;
      WriteSvgFile(cmd.plot, file.graph, &before, &file.values, po);
      out << "wrote " << cmd.plot << "\n";
    }
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
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
  const SimulatedGraph sim = Simulate(so);
  try {
    WriteG2oFile(cmd.output, sim.initial, sim.graph, DefaultRegistry());
    if (!cmd.ground_truth.empty()) WriteG2oFile(cmd.ground_truth, sim.ground_truth, sim.graph, DefaultRegistry());
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return 1;
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
  if (!LoadPlugins(cmd.plugins, &loader, out, err)) return 1;
  out << "plugin search path (after explicit paths):";
  for (const std::string& d : PluginLoader::SearchPath()) out << " " << d;
  out << "\n";
  char line[256];
  std::snprintf(line, sizeof(line), "%-20s %-24s %4s  %-20s %s\n", "type", "g2o tag", "dim", "variables", "owner");
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
