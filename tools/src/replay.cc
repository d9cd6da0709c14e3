#include "tether/tools/replay.h"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <ostream>
#include <unordered_map>
#include <utility>
#include <vector>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/core/timing.h"
#include "tether/factors/builtin.h"
#include "tether/solvers/incremental_smoother.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/optimizer.h"
#include "tether/tools/command.h"
#include "tether/tools/commands.h"
#include "tether/tools/latency_plot.h"

namespace tether {

namespace {

std::string Format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, v);
  return buf;
}

// The initial guess of `key`, added at this step: from the edges of this step to variables
// added before (in the estimate, the pending values, or `done`: those that left a fixed-lag window) (the one to
// `previous` first), through the edge's Predict; else the file's.
void InitialGuess(const GraphFile& file, const std::vector<std::size_t>& factors, Key key, Key previous,
                  const Values& estimate, const Values& pending, const Values* done, double* params) {
  auto known_params = [&](Key k) -> const double* {
    if (estimate.Has(k)) return estimate.Params(k);
    if (pending.Has(k)) return pending.Params(k);
    if (done->Has(k)) return done->Params(k);
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

// The variables in id order, and the factors to add at each step (each at the step of its
// last variable).
struct Schedule {
  std::vector<Key> keys;
  std::vector<std::vector<std::size_t>> by_step;
};

Schedule MakeSchedule(const GraphFile& file) {
  Schedule s;
  s.keys = file.values.keys();
  std::sort(s.keys.begin(), s.keys.end());
  std::unordered_map<Key, std::size_t> step_of;
  for (std::size_t i = 0; i < s.keys.size(); ++i) step_of[s.keys[i]] = i;
  s.by_step.resize(s.keys.size());
  for (std::size_t j = 0; j < file.graph.size(); ++j) {
    std::size_t step = 0;
    for (Key k : file.graph.at(j).keys()) step = std::max(step, step_of.at(k));
    s.by_step[step].push_back(j);
  }
  return s;
}

ReplayResult Failed(ReplayResult r, ReplayStatus status, std::string message) {
  r.status = status;
  r.message = std::move(message);
  return r;
}

// Mean, p99 (nearest rank) and max of the latencies.
void LatencyStatistics(ReplayResult* r) {
  const LatencyStats st = ComputeLatencyStats(r->latencies);
  r->updates_seconds = st.sum;
  r->mean_seconds = st.mean;
  r->p99_seconds = st.p99;
  r->max_seconds = st.max;
}

void Accumulate(const SmootherUpdate& u, ReplayResult* r) {
  r->solves += u.solved ? 1 : 0;
  r->rebuilt += u.structure_rebuilt ? 1 : 0;
  r->fell_back += u.fell_back ? 1 : 0;
  r->batches += u.batch ? 1 : 0;
  r->region_variables += u.region;
  r->iterations += u.iterations;
  r->affected_columns += u.affected_columns;
  r->back_substituted += u.back_substituted;
  r->relinearized += u.relinearized;
  r->linearize_seconds += u.linearize_seconds;
  r->factorize_seconds += u.factorize_seconds;
  r->solve_seconds += u.solve_seconds;
}

// The online chi2 of the graph so far, computed from the smoother's graph and estimate, and
// the batch optimum of that graph from the same start (neither timed).
ReplayCheck Check(const FactorGraph& graph, const Values& estimate, const SolverOptions& finish, std::size_t step) {
  ReplayCheck c;
  c.step = step;
  c.online_chi2 = graph.Chi2(estimate);
  Values batch = estimate;
  const SolverSummary s = Optimize(graph, &batch, finish);
  c.batch_chi2 = s.final_chi2;
  c.gap = RelativeChi2Gap(c.online_chi2, c.batch_chi2);
  return c;
}

// The batch optimum of the whole file, from the chordal start; false (and `why`) on failure.
bool BatchOptimum(const GraphFile& file, double* chi2, std::string* why) {
  Values batch = file.values;
  SolverSummary bs;
  try {
    Initialize(file.graph, &batch, InitMethod::kChordal);
    bs = Optimize(file.graph, &batch);
  } catch (const Error& e) {
    *why = std::string("batch solve: ") + e.what();
    return false;
  }
  if (!bs.IsSolutionUsable()) {
    *why = "batch solve failed: " + bs.message;
    return false;
  }
  *chi2 = bs.final_chi2;
  return true;
}

// Whether a factor can go into the smoother: always, but a factor that reaches a variable the
// fixed-lag smoother marginalised cannot.
bool Reachable(const IncrementalSmoother&, const Factor&) { return true; }
bool Reachable(const FixedLagSmoother& smoother, const Factor& f) {
  for (Key k : f.keys()) {
    if (smoother.WasMarginalized(k)) return false;
  }
  return true;
}

// After each update: the fixed-lag smoother's marginalised variables go into *done (their
// final estimates), and the largest window is recorded.
void AfterUpdate(IncrementalSmoother*, ReplayResult*, Values*) {}
void AfterUpdate(FixedLagSmoother* smoother, ReplayResult* r, Values* done) {
  const Values out = smoother->TakeMarginalized();
  for (Key k : out.keys()) done->InsertParams(k, out.TypeOf(k), out.Params(k));
  r->marginalized = smoother->marginalized();
  r->largest_window = std::max(r->largest_window, smoother->Estimate().size());
}

// The replay's status, message and latency statistics where it stops early; false.
bool Fail(ReplayResult* r, ReplayStatus status, std::string message) {
  LatencyStatistics(r);
  *r = Failed(std::move(*r), status, std::move(message));
  return false;
}

// Feeds the file's variables and factors into `smoother` step by step (the header's
// schedule), timing each update, with the checks asked for. False (and r's status) where an
// update is refused or fails, or a check fails. `done` holds the estimates of the variables
// that left the smoother (fixed lag), for the initial guesses.
template <class Smoother>
bool FeedUpdates(const GraphFile& file, const Schedule& schedule, const ReplayOptions& ro, Smoother* smoother,
                 ReplayResult* r, const std::function<void(const ReplayCheck&)>& on_check, Values* done = nullptr) {
  Values none;
  if (done == nullptr) done = &none;
  const std::vector<Key>& keys = schedule.keys;
  FactorGraph pending_factors;
  Values pending_values;
  std::vector<double> params(16);
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const Key key = keys[i];
    params.assign(static_cast<std::size_t>(AmbientDim(file.values.TypeOf(key))), 0.0);
    InitialGuess(file, schedule.by_step[i], key, i > 0 ? keys[i - 1] : key, smoother->Estimate(), pending_values, done,
                 params.data());
    pending_values.InsertParams(key, file.values.TypeOf(key), params.data());
    if (file.graph.IsFixed(key)) pending_factors.Fix(key);
    for (std::size_t j : schedule.by_step[i]) {
      if (Reachable(*smoother, file.graph.at(j))) {
        pending_factors.Add(file.graph.at(j).Clone());
      } else {
        ++r->beyond_lag;
      }
    }
    if ((i + 1) % static_cast<std::size_t>(ro.every) != 0 && i + 1 != keys.size()) continue;

    const auto t0 = std::chrono::steady_clock::now();
    SmootherUpdate u;
    try {
      u = smoother->Update(std::move(pending_factors), std::move(pending_values));
    } catch (const Error& e) {
      return Fail(r, ReplayStatus::kBadInput, "the update at step " + std::to_string(i) + ": " + e.what());
    }
    r->latencies.push_back(SecondsSince(t0));
    r->update_steps.push_back(i);
    Accumulate(u, r);
    pending_factors = FactorGraph();
    pending_values = Values();
    AfterUpdate(smoother, r, done);
    if (ro.time_marginal && smoother->Estimate().Has(key) && !smoother->graph().IsFixed(key)) {
      const auto tm = std::chrono::steady_clock::now();
      try {
        smoother->Marginal(key);
        const double s = SecondsSince(tm);
        ++r->marginals;
        r->marginal_seconds += s;
        r->marginal_max_seconds = std::max(r->marginal_max_seconds, s);
      } catch (const Error&) {
        // The gauge, or a variable no factor uses yet: nothing to time.
      }
    }
    if (u.solved && u.status != SolverStatus::kConverged && u.status != SolverStatus::kMaxIterations) {
      return Fail(r, ReplayStatus::kSolveFailed,
                  "the update at step " + std::to_string(i) + " failed: " + ToString(u.status) + ": " + u.message);
    }
    if (ro.check > 0 && r->latencies.size() % static_cast<std::size_t>(ro.check) == 0 && !smoother->graph().empty()) {
      try {
        r->checks.push_back(Check(smoother->graph(), smoother->Estimate(), ro.smoother.finish, i));
      } catch (const Error& e) {
        return Fail(r, ReplayStatus::kSolveFailed, "the check at step " + std::to_string(i) + ": " + e.what());
      }
      r->max_check_gap = std::max(r->max_check_gap, r->checks.back().gap);
      if (on_check) on_check(r->checks.back());
    }
  }
  LatencyStatistics(r);
  return true;
}

// The replay through FixedLagSmoother (ReplayOptions::fixed_lag), after ReplayFile's checks and
// reading: the final estimate is each variable's last, the window's after Finish().
ReplayResult ReplayFixedLag(const GraphFile& file, const Schedule& schedule, const ReplayOptions& ro,
                            OutputFile* output, bool commit, ReplayResult r,
                            const std::function<void(const ReplayCheck&)>& on_check) {
  FixedLagOptions fo;
  fo.lag = ro.lag;
  fo.batch = ro.lag_batch;
  fo.smoother = ro.smoother;
  FixedLagSmoother smoother(fo);
  Values all;  // the marginalised variables' final estimates, then the window's
  if (!FeedUpdates(file, schedule, ro, &smoother, &r, on_check, &all)) return r;
  const auto t_finish = std::chrono::steady_clock::now();
  try {
    smoother.Finish();
  } catch (const Error& e) {
    return Failed(std::move(r), ReplayStatus::kSolveFailed, std::string("Finish: ") + e.what());
  }
  r.finish_seconds = SecondsSince(t_finish);
  r.peak_rss_mib = PeakRssMib();
  for (Key k : smoother.Estimate().keys()) {
    all.InsertParams(k, smoother.Estimate().TypeOf(k), smoother.Estimate().Params(k));
  }
  r.final_chi2 = file.graph.Chi2(all);
  std::string why;
  if (!BatchOptimum(file, &r.batch_chi2, &why)) return Failed(std::move(r), ReplayStatus::kSolveFailed, why);
  r.relative_gap = RelativeChi2Gap(r.final_chi2, r.batch_chi2);
  if (output != nullptr) {
    try {
      output->Stage([&](std::ostream& s) { WriteG2o(s, all, file.graph, DefaultRegistry()); });
      if (commit) output->Commit();
    } catch (const Error& e) {
      return Failed(std::move(r), ReplayStatus::kWriteFailed, e.what());
    }
  }
  return r;
}

}  // namespace

bool ReplayOptions::IsValid(std::string* why) const {
  std::string reason;
  if (every < 1) {
    reason = "--every must be at least 1";
  } else if (check < 0) {
    reason = "--check must be 0 (never) or more";
  } else if (fixed_lag && !(lag >= 0 && std::isfinite(lag))) {
    reason = "--lag must be 0 or more";
  } else if (fixed_lag && !(lag_batch >= 0 && std::isfinite(lag_batch))) {
    reason = "--lag-batch must be 0 or more";
  }
  if (why != nullptr) *why = reason;
  return reason.empty();
}

double RelativeChi2Gap(double online, double batch) { return (online - batch) / std::max(batch, 1e-6); }

double PeakRssMib() {
  struct rusage usage {};
  if (::getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

ReplayResult ReplayFile(const std::string& path, const ReplayOptions& ro,
                        const std::function<void(const ReplayCheck&)>& on_check) {
  ReplayResult r;
  std::string why;
  if (!ro.IsValid(&why)) return Failed(std::move(r), ReplayStatus::kBadUsage, why);
  const SmootherOptions& options = ro.smoother;
  if (!options.IsValid(&why)) return Failed(std::move(r), ReplayStatus::kBadUsage, why);
  Registry& registry = DefaultRegistry();
  // The output path is checked before the replay: a typo costs no replay.
  std::unique_ptr<OutputFile> own_output;
  OutputFile* output = ro.output_file;
  if (output == nullptr && !ro.output.empty()) {
    try {
      OutputSet check;
      check.AddInput(path, "input graph");
      check.Add(ro.output, "final estimate");
      own_output = std::make_unique<OutputFile>(ro.output, "final estimate");
      output = own_output.get();
    } catch (const Error& e) {
      return Failed(std::move(r), ReplayStatus::kWriteFailed, e.what());
    }
  }
  GraphFile file;
  try {
    file = ReadGraphFile(path, registry);
  } catch (const Error& e) {
    return Failed(std::move(r), ReplayStatus::kBadInput, e.what());
  }
  r.warnings = file.warnings;
  const Schedule schedule = MakeSchedule(file);
  const std::vector<Key>& keys = schedule.keys;
  r.variables = keys.size();
  r.poses = file.values.Count(VarType::kSE2) + file.values.Count(VarType::kSE3);
  r.factors = file.graph.size();

  if (ro.fixed_lag) return ReplayFixedLag(file, schedule, ro, output, own_output != nullptr, std::move(r), on_check);
  IncrementalSmoother smoother(options);
  if (!FeedUpdates(file, schedule, ro, &smoother, &r, on_check)) return r;

  const auto t_finish = std::chrono::steady_clock::now();
  try {
    smoother.Finish();
  } catch (const Error& e) {
    return Failed(std::move(r), ReplayStatus::kSolveFailed, std::string("Finish: ") + e.what());
  }
  r.finish_seconds = SecondsSince(t_finish);
  r.peak_rss_mib = PeakRssMib();
  const SolverSummary& fs = smoother.finish_summary();
  if (!fs.IsSolutionUsable()) return Failed(std::move(r), ReplayStatus::kSolveFailed, "Finish failed: " + fs.message);
  r.final_chi2 = fs.final_chi2;

  if (!BatchOptimum(file, &r.batch_chi2, &why)) return Failed(std::move(r), ReplayStatus::kSolveFailed, why);
  r.relative_gap = RelativeChi2Gap(r.final_chi2, r.batch_chi2);

  if (output != nullptr) {
    try {
      output->Stage([&](std::ostream& s) { WriteG2o(s, smoother.Estimate(), smoother.graph(), registry); });
      if (own_output) output->Commit();
    } catch (const Error& e) {
      return Failed(std::move(r), ReplayStatus::kWriteFailed, e.what());
    }
  }
  return r;
}

namespace {

// The settings the replay runs with, said before it starts.
void PrintSettings(const ReplayCommand& cmd, std::ostream& out) {
  const ReplayOptions& o = cmd.options;
  if (o.fixed_lag) {
    out << "replay " << cmd.input << ": fixed lag, variables older than " << o.lag
        << " step(s) marginalised in batches of " << o.lag_batch << " of the lag; ";
  }
  if (o.smoother.mode == SmootherMode::kLocal) {
    if (!o.fixed_lag) out << "replay " << cmd.input << ": ";
    out << "an update every " << o.every << " step(s), local mode: tolerance " << o.smoother.local_tolerance << ", "
        << o.smoother.local_hops << " hop(s), regions of at most " << o.smoother.local_max_region
        << " variables, a batch solve once the edges leave " << o.smoother.local_batch_gap << " of chi2 or after "
        << o.smoother.local_batch_share << " of the variables in updates, new variables "
        << (o.smoother.refine_new_values ? "refined" : "as given") << "\n";
  } else {
    if (!o.fixed_lag) out << "replay " << cmd.input << ": ";
    out << "an update every " << o.every << " step(s), relinearise threshold " << o.smoother.relinearize_threshold
        << " or " << o.smoother.relinearize_sigmas << " sigma, iterate ratio " << o.smoother.iterate_ratio
        << " (then beyond " << o.smoother.iterate_fraction << " of them) or " << o.smoother.iterate_share
        << " of the variables too large, new variables " << (o.smoother.refine_new_values ? "refined" : "as given")
        << ", at most " << o.smoother.rounds_per_update << " round(s) per update, wildfire "
        << o.smoother.wildfire_threshold << ", factorization " << o.smoother.factorization << "\n";
  }
}

// What the replay measured.
void PrintReplayReport(const ReplayResult& r, const ReplayOptions& o, std::ostream& out) {
  out << "graph: " << r.variables << " variables (" << r.poses << " poses), " << r.factors << " factors\n";
  out << "updates: " << r.latencies.size() << " (" << r.solves << " solved, " << r.rebuilt << " rebuilt the factor, "
      << r.fell_back << " fell back to batch, " << r.iterations << " rounds)\n";
  if (o.smoother.mode == SmootherMode::kLocal) {
    const int local = static_cast<int>(r.latencies.size()) - r.batches;
    out << "local mode: " << r.batches << " batch solve(s), " << local << " local solve(s) over "
        << Format("%.1f", local > 0 ? static_cast<double>(r.region_variables) / local : 0.0)
        << " variables on average\n";
  }
  if (o.fixed_lag) {
    out << "fixed lag: " << r.marginalized << " variables marginalised, a window of at most " << r.largest_window
        << " variables, " << r.beyond_lag << " factor(s) left out (they reached beyond the lag)\n";
  }
  out << "columns refactored: " << r.affected_columns << ", back-substituted: " << r.back_substituted
      << ", variables re-linearised: " << r.relinearized << "\n";
  out << "total [s]: " << Format("%.3f", r.total_seconds()) << " (updates " << Format("%.3f", r.updates_seconds)
      << ", finish " << Format("%.3f", r.finish_seconds) << ")\n";
  out << "per step [ms]: mean " << Format("%.3f", 1e3 * r.mean_seconds) << ", p99 "
      << Format("%.3f", 1e3 * r.p99_seconds) << ", max " << Format("%.3f", 1e3 * r.max_seconds) << "\n";
  out << "update split [s]: linearise " << Format("%.3f", r.linearize_seconds) << ", factorise "
      << Format("%.3f", r.factorize_seconds) << ", solve " << Format("%.3f", r.solve_seconds) << ", other "
      << Format("%.3f", r.updates_seconds - r.linearize_seconds - r.factorize_seconds - r.solve_seconds) << "\n";
  if (r.marginals > 0) {
    const double mean = r.marginal_seconds / static_cast<double>(r.marginals);
    out << "marginal of the newest variable [ms]: mean " << Format("%.3f", 1e3 * mean) << ", max "
        << Format("%.3f", 1e3 * r.marginal_max_seconds) << " (" << r.marginals << " calls; "
        << Format("%.3f", r.mean_seconds > 0 ? mean / r.mean_seconds : 0.0) << " of the mean update)\n";
  }
  out << (o.fixed_lag ? "final chi2 (the whole file at each variable's last estimate): " : "final chi2: ")
      << Format("%.9g", r.final_chi2) << "\n";
  out << "batch optimum: " << Format("%.9g", r.batch_chi2) << "\n";
  out << "relative gap to batch: " << Format("%.3e", r.relative_gap) << "\n";
  if (o.check > 0) {
    out << "check: " << r.checks.size()
        << " batch solves, largest relative chi2 gap: " << Format("%.3e", r.max_check_gap) << "\n";
  }
  out << "peak memory [MiB]: " << Format("%.1f", r.peak_rss_mib) << "\n";
}

}  // namespace

int RunReplay(const ReplayCommand& cmd, std::ostream& out, std::ostream& err) {
  const ReplayOptions& o = cmd.options;
  std::string why;
  if (!o.IsValid(&why)) {
    err << "error: " << why << "\n";
    return kExitUsage;
  }
  PrintSettings(cmd, out);
  out << std::flush;
  const auto print_check = [&](const ReplayCheck& c) {
    if (cmd.quiet) return;
    out << "check at step " << c.step << ": online chi2 " << Format("%.9g", c.online_chi2) << ", batch "
        << Format("%.9g", c.batch_chi2) << ", relative gap " << Format("%.3e", c.gap) << "\n"
        << std::flush;
  };
  // Both outputs are checked before the replay and committed together after it.
  OutputSet outputs;
  OutputFile* plot_file = nullptr;
  ReplayOptions ro = o;
  const int rc = CheckOutputs(
      "replay", outputs,
      [&] {
        outputs.AddInput(cmd.input, "input graph");
        if (!o.output.empty()) ro.output_file = &outputs.Add(o.output, "final estimate");
        if (!cmd.plot.empty()) plot_file = &outputs.Add(cmd.plot, "latency plot");
      },
      err);
  if (rc != 0) return rc;
  const ReplayResult r = ReplayFile(cmd.input, ro, print_check);
  for (const std::string& w : r.warnings) err << "warning: " << w << "\n";
  switch (r.status) {
    case ReplayStatus::kDone:
      break;
    case ReplayStatus::kBadUsage:
      err << "error: " << r.message << "\n";
      return kExitUsage;
    case ReplayStatus::kBadInput:
      err << "error: " << r.message << "\n";
      return kExitBadInput;
    case ReplayStatus::kSolveFailed:
      err << "error: " << r.message << "\n";
      return kExitSolveFailed;
    case ReplayStatus::kWriteFailed:
      err << "error: " << r.message << "\n";
      return kExitWriteFailed;
  }

  PrintReplayReport(r, o, out);
  if (plot_file != nullptr) {
    LatencyPlotOptions po;
    po.title = "tether replay " + std::filesystem::path(cmd.input).filename().string() + ": update latency";
    try {
      plot_file->Stage(RenderLatencySvg(r.update_steps, r.latencies, po));
    } catch (const Error& e) {
      err << "error: " << e.what() << "; nothing was written\n";
      return kExitWriteFailed;
    }
  }
  try {
    outputs.CommitAll();
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return kExitWriteFailed;
  }
  if (ro.output_file != nullptr) out << "wrote " << o.output << "\n";
  if (plot_file != nullptr) out << "wrote " << cmd.plot << "\n";
  return 0;
}

namespace {

class ReplayCli : public Command {
 public:
  void Add(CLI::App& app) override;
  int Run(std::ostream& out, std::ostream& err) override { return RunReplay(cmd_, out, err); }

 private:
  ReplayCommand cmd_;
};

// --mode, and the options of the fixed-lag and local modes.
void AddModeOptions(CLI::App* sub, ReplayOptions* o) {
  sub->add_option_function<std::string>(
         "--mode",
         [o](const std::string& m) {
           o->fixed_lag = m == "fixed-lag";
           if (!o->fixed_lag) FromString(m, &o->smoother.mode);
         },
         "factor (keep a Cholesky factor of the whole system), local (solve each update over a region around it, "
         "with batch solves now and then) (SmootherOptions::mode), or fixed-lag (marginalise what is older than "
         "--lag: FixedLagSmoother, with the factor mode's smoother over the window)")
      ->type_name("NAME")
      ->default_str("factor")
      ->check(CLI::IsMember({"factor", "local", "fixed-lag"}));
  sub->add_option("--lag", o->lag,
                  "fixed-lag: marginalise the variables added more than this many steps before (FixedLagOptions::lag)")
      ->capture_default_str();
  sub->add_option("--lag-batch", o->lag_batch,
                  "fixed-lag: marginalise once the oldest variable is older than lag * (1 + this) "
                  "(FixedLagOptions::batch)")
      ->capture_default_str();
  sub->add_option("--local-tolerance", o->smoother.local_tolerance,
                  "local: grow the region while an edge variable alone could lower chi2 by more than this share of "
                  "chi2 per variable "
                  "(SmootherOptions::local_tolerance)")
      ->capture_default_str();
  sub->add_option("--local-hops", o->smoother.local_hops,
                  "local: the first region reaches this many factors from the update's variables "
                  "(SmootherOptions::local_hops)")
      ->capture_default_str();
  sub->add_option("--local-max-region", o->smoother.local_max_region,
                  "local: solve in batch where a region would grow beyond this many variables "
                  "(SmootherOptions::local_max_region)")
      ->capture_default_str();
  sub->add_option("--local-batch-gap", o->smoother.local_batch_gap,
                  "local: a batch solve once the edge gains since the last reach this share of chi2 "
                  "(SmootherOptions::local_batch_gap)")
      ->capture_default_str();
  sub->add_option("--local-batch-correction", o->smoother.local_batch_correction,
                  "local: solve in batch an update whose local solve lowers chi2 by more than this share of it "
                  "(SmootherOptions::local_batch_correction)")
      ->capture_default_str();
  sub->add_option("--local-batch-share", o->smoother.local_batch_share,
                  "local: a batch solve at the latest once the updates since the last reach this share of the "
                  "variables "
                  "(SmootherOptions::local_batch_share)")
      ->capture_default_str();
}

void ReplayCli::Add(CLI::App& app) {
  CLI::App* sub = app_ =
      app.add_subcommand("replay", "Feed a graph file into the incremental smoother pose by pose and time each update");
  sub->add_option("input", cmd_.input, "Graph file (.g2o, TORO .graph, or iSAM landmark text)")->required();
  sub->add_option("--every", cmd_.options.every, "Update the estimate every N-th pose")->capture_default_str();
  sub->add_option("--check", cmd_.options.check,
                  "Every K-th update, solve the graph so far in batch (untimed) and compare")
      ->capture_default_str();
  AddPath(sub, "-o,--output", &cmd_.options.output, "Write the final estimate (g2o)");
  AddPath(sub, "--plot", &cmd_.plot, "Write an SVG of every update's latency (mean, p99 and max marked)");
  sub->add_flag("-q,--quiet", cmd_.quiet, "Only the summary lines");
  sub->add_flag("--time-marginal", cmd_.options.time_marginal,
                "After each update, time Marginal() of the variable that step added (not counted in the update)");
  sub->add_flag_function(
      "--no-marginal-from-factor", [this](std::int64_t) { cmd_.options.smoother.marginal_from_factor = false; },
      "Marginal() through tether::Marginals at the estimate always, not from the kept factor "
      "(SmootherOptions::marginal_from_factor)");
  sub->add_option("--relinearize-threshold", cmd_.options.smoother.relinearize_threshold,
                  "Re-linearise a variable whose step exceeds this (SmootherOptions::relinearize_threshold)")
      ->capture_default_str();
  sub->add_option("--relinearize-sigmas", cmd_.options.smoother.relinearize_sigmas,
                  "Re-linearise a variable whose step exceeds this many standard deviations "
                  "(SmootherOptions::relinearize_sigmas)")
      ->capture_default_str();
  sub->add_option(
         "--iterate-ratio", cmd_.options.smoother.iterate_ratio,
         "Solve again within an update while a step is this many times too large (SmootherOptions::iterate_ratio)")
      ->capture_default_str();
  sub->add_option("--iterate-fraction", cmd_.options.smoother.iterate_fraction,
                  "When solving again, also re-linearise steps beyond this fraction of the thresholds "
                  "(SmootherOptions::iterate_fraction)")
      ->capture_default_str();
  sub->add_option("--iterate-share", cmd_.options.smoother.iterate_share,
                  "Solve again within an update while more than this share of the variables have steps too large "
                  "(SmootherOptions::iterate_share)")
      ->capture_default_str();
  sub->add_flag_function(
      "--no-refine-new", [this](std::int64_t) { cmd_.options.smoother.refine_new_values = false; },
      "Start new variables at the given values, not at the optimum of their new factors "
      "(SmootherOptions::refine_new_values)");
  sub->add_option("--rounds", cmd_.options.smoother.rounds_per_update,
                  "Factorise-solve rounds per update (SmootherOptions::rounds_per_update)")
      ->capture_default_str();
  AddEnumOption(sub, "--factorization", &cmd_.options.smoother.factorization,
                "auto, left-looking or multifrontal (SmootherOptions::factorization)");
  sub->add_option("--wildfire", cmd_.options.smoother.wildfire_threshold,
                  "Back-substitute below a variable only where its step changed by more than this "
                  "(SmootherOptions::wildfire_threshold)")
      ->capture_default_str();
  AddModeOptions(sub, &cmd_.options);
}

}  // namespace

std::unique_ptr<Command> MakeReplayCommand() { return std::make_unique<ReplayCli>(); }

}  // namespace tether
