#include "tether/tools/replay.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ostream>
#include <unordered_map>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/factors/builtin.h"
#include "tether/solvers/incremental_smoother.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/optimizer.h"

namespace tether {

namespace {

double SecondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::string Format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, v);
  return buf;
}

// (online - batch) / batch, with chi2 below 1e-6 counted as 1e-6 (a graph of odometry alone
// has chi2 0 at its optimum, where any rounding would be an infinite relative gap).
double RelativeGap(double online, double batch) { return (online - batch) / std::max(batch, 1e-6); }

// The initial guess of `key`, added at this step: from the edges of this step to variables
// added before (the one to `previous` first), through the edge's Predict; else the file's.
void InitialGuess(const GraphFile& file, const std::vector<std::size_t>& factors, Key key, Key previous,
                  const Values& estimate, const Values& pending, double* params) {
  auto known_params = [&](Key k) -> const double* {
    if (estimate.Has(k)) return estimate.Params(k);
    if (pending.Has(k)) return pending.Params(k);
    return nullptr;
  };
  for (int pass = 0; pass < 2; ++pass) {
    for (std::size_t j : factors) {
      const Factor& f = file.graph.at(j);
      if (f.keys().size() != 2) continue;
      const std::size_t unknown = f.keys()[0] == key ? 0 : 1;
      const std::size_t known = 1 - unknown;
      if (f.keys()[unknown] != key || f.keys()[known] == key) continue;
      if (pass == 0 && f.keys()[known] != previous) continue;
      const double* p = known_params(f.keys()[known]);
      if (p && f.Predict(known, p, unknown, params)) return;
    }
  }
  const double* p = file.values.Params(key);
  std::copy(p, p + AmbientDim(file.values.TypeOf(key)), params);
}

}  // namespace

int RunReplay(const ReplayCommand& cmd, std::ostream& out, std::ostream& err) {
  if (cmd.every < 1) {
    err << "error: --every must be at least 1\n";
    return 2;
  }
  if (cmd.check < 0) {
    err << "error: --check must be 0 (never) or more\n";
    return 2;
  }
  SmootherOptions options;
  options.rounds_per_update = cmd.update_iterations;
  options.relinearize_threshold = cmd.update_tolerance;
  std::string why;
  if (!options.IsValid(&why)) {
    err << "error: " << why << "\n";
    return 2;
  }
  Registry& registry = DefaultRegistry();
  GraphFile file;
  try {
    file = ReadGraphFile(cmd.input, registry);
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return 1;
  }
  for (const std::string& w : file.warnings) err << "warning: " << w << "\n";

  // The variables in id order, and each factor at the step of its last variable.
  std::vector<Key> keys = file.values.keys();
  std::sort(keys.begin(), keys.end());
  std::unordered_map<Key, std::size_t> step_of;
  for (std::size_t i = 0; i < keys.size(); ++i) step_of[keys[i]] = i;
  std::vector<std::vector<std::size_t>> by_step(keys.size());
  for (std::size_t j = 0; j < file.graph.size(); ++j) {
    std::size_t step = 0;
    for (Key k : file.graph.at(j).keys()) step = std::max(step, step_of.at(k));
    by_step[step].push_back(j);
  }
  out << "replay " << cmd.input << ": " << keys.size() << " variables, " << file.graph.size()
      << " factors, an update every " << cmd.every << " step(s), at most " << cmd.update_iterations
      << " iterations each (function tolerance " << cmd.update_tolerance << ")"
      << (cmd.no_skip ? ", never skipped" : "") << "\n";

  IncrementalSmoother smoother(options);
  std::vector<double> latencies;
  double max_check_gap = 0;
  int checks = 0;
  int solves = 0, skipped = 0, iterations = 0;
  long long affected = 0, backsub = 0, relin = 0;
  double setup = 0, linearize = 0, factorize = 0, solve = 0;  // summed over the updates
  FactorGraph pending_factors;
  Values pending_values;
  std::vector<double> params(16);
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const Key key = keys[i];
    params.assign(static_cast<std::size_t>(AmbientDim(file.values.TypeOf(key))), 0.0);
    InitialGuess(file, by_step[i], key, i > 0 ? keys[i - 1] : key, smoother.Estimate(), pending_values, params.data());
    pending_values.InsertParams(key, file.values.TypeOf(key), params.data());
    if (file.graph.IsFixed(key)) pending_factors.Fix(key);
    for (std::size_t j : by_step[i]) pending_factors.Add(file.graph.at(j).Clone());
    if ((i + 1) % static_cast<std::size_t>(cmd.every) != 0 && i + 1 != keys.size()) continue;

    const auto t0 = std::chrono::steady_clock::now();
    SmootherUpdate u;
    try {
      u = smoother.Update(std::move(pending_factors), std::move(pending_values));
    } catch (const Error& e) {
      err << "error: the update at step " << i << ": " << e.what() << "\n";
      return 1;
    }
    latencies.push_back(SecondsSince(t0));
    solves += u.solved ? 1 : 0;
    skipped += u.structure_rebuilt ? 1 : 0;
    iterations += u.iterations;
    affected += u.affected_columns;
    backsub += u.back_substituted;
    relin += u.relinearized;
    setup += 0;
    linearize += u.linearize_seconds;
    factorize += u.factorize_seconds;
    solve += u.solve_seconds;
    pending_factors = FactorGraph();
    pending_values = Values();
    if (u.solved && u.status != SolverStatus::kConverged && u.status != SolverStatus::kMaxIterations) {
      err << "error: the update at step " << i << " failed: " << ToString(u.status) << ": " << u.message << "\n";
      return 3;
    }
    if (cmd.check > 0 && latencies.size() % static_cast<std::size_t>(cmd.check) == 0 && !smoother.graph().empty()) {
      Values batch = smoother.Estimate();
      const SolverSummary s = Optimize(smoother.graph(), &batch, smoother.options().finish);
      const double online = smoother.graph().Chi2(smoother.Estimate());
      const double gap = RelativeGap(online, s.final_chi2);
      max_check_gap = std::max(max_check_gap, gap);
      ++checks;
      if (!cmd.quiet) {
        out << "check at step " << i << ": online chi2 " << Format("%.9g", online) << ", batch "
            << Format("%.9g", s.final_chi2) << ", relative gap " << Format("%.3e", gap) << "\n";
      }
    }
  }
  double updates_seconds = 0;
  for (double s : latencies) updates_seconds += s;

  const auto t_finish = std::chrono::steady_clock::now();
  smoother.Finish();
  const double finish_seconds = SecondsSince(t_finish);
  const SolverSummary& fs = smoother.finish_summary();
  if (!fs.IsSolutionUsable()) {
    err << "error: Finish failed: " << fs.message << "\n";
    return 3;
  }

  // The batch optimum of the whole file, from the chordal start.
  Values batch = file.values;
  SolverSummary bs;
  try {
    Initialize(file.graph, &batch, InitMethod::kChordal);
    bs = Optimize(file.graph, &batch);
  } catch (const Error& e) {
    err << "error: batch solve: " << e.what() << "\n";
    return 3;
  }
  if (!bs.IsSolutionUsable()) {
    err << "error: batch solve failed: " << bs.message << "\n";
    return 3;
  }

  std::vector<double> sorted = latencies;
  std::sort(sorted.begin(), sorted.end());
  const std::size_t n = sorted.size();
  const double mean = n ? updates_seconds / static_cast<double>(n) : 0;
  // p99 by the nearest rank: the smallest latency at least 99% of the updates do not exceed.
  const double p99 = n ? sorted[static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(n))) - 1] : 0;
  const double max = n ? sorted.back() : 0;
  out << "updates: " << n << " (" << solves << " solved, " << skipped << " skipped, " << iterations << " iterations)\n";
  out << "columns refactored: " << affected << ", back-substituted: " << backsub << ", relinearised: " << relin << "\n";
  out << "total [s]: " << Format("%.3f", updates_seconds + finish_seconds) << " (updates "
      << Format("%.3f", updates_seconds) << ", finish " << Format("%.3f", finish_seconds) << ")\n";
  out << "per step [ms]: mean " << Format("%.3f", 1e3 * mean) << ", p99 " << Format("%.3f", 1e3 * p99) << ", max "
      << Format("%.3f", 1e3 * max) << "\n";
  out << "update split [s]: setup " << Format("%.3f", setup) << ", linearise " << Format("%.3f", linearize)
      << ", factorise " << Format("%.3f", factorize) << ", solve " << Format("%.3f", solve) << ", other "
      << Format("%.3f", updates_seconds - setup - linearize - factorize - solve) << "\n";
  out << "final chi2: " << Format("%.9g", fs.final_chi2) << "\n";
  out << "batch optimum: " << Format("%.9g", bs.final_chi2) << "\n";
  out << "relative gap to batch: " << Format("%.3e", RelativeGap(fs.final_chi2, bs.final_chi2)) << "\n";
  if (cmd.check > 0) {
    out << "check: " << checks << " batch solves, largest relative chi2 gap: " << Format("%.3e", max_check_gap) << "\n";
  }
  if (!cmd.output.empty()) {
    try {
      WriteG2oFile(cmd.output, smoother.Estimate(), smoother.graph(), registry);
    } catch (const Error& e) {
      err << "error: " << e.what() << "\n";
      return 1;
    }
    out << "wrote " << cmd.output << "\n";
  }
  return 0;
}

}  // namespace tether
