#include "tether/tools/outlier_bench.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <set>

#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/core/robust_kernels.h"
#include "tether/core/robust_rules.h"
#include "tether/core/timing.h"
#include "tether/core/trajectory_error.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/builtin.h"
#include "tether/solvers/chunked_solve.h"
#include "tether/solvers/gnc.h"
#include "tether/solvers/initialize.h"
#include "tether/solvers/optimizer.h"
#include "tether/solvers/switchable.h"

namespace tether {
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// A random relative pose of the type of key k.
template <class Rng>
void RandomRelative(bool se3, Rng& rng, SE2d* z2, SE3d* z3) {
  std::uniform_real_distribution<double> t(-10, 10), angle(-M_PI, M_PI);
  if (!se3) {
    *z2 = SE2d(t(rng), t(rng), angle(rng));
    return;
  }
  std::normal_distribution<double> n(0, 1);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  q.normalize();
  *z3 = SE3d(SO3d(q), Eigen::Vector3d(t(rng), t(rng), t(rng)));
}

struct Truth {
  FactorGraph graph;  // as read: loop closures marked
  Values initial;     // the file's start
  Values optimum;     // least squares without false closures
  double chi2 = 0, seconds = 0;
  std::vector<Key> poses;
  std::vector<const Factor*> closures;
};

// Adds `count` false closures to *graph; their indices go to *wrong.
void AddFalseClosures(const Truth& t, int count, bool grouped, std::uint64_t seed, FactorGraph* graph,
                      std::set<std::size_t>* wrong) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<std::size_t> pick(0, t.poses.size() - 1), closure(0, t.closures.size() - 1);
  const bool se3 = t.optimum.TypeOf(t.poses.front()) == VarType::kSE3;
  auto add = [&](Key a, Key b, const SE2d& z2, const SE3d& z3, const SqrtInformation& noise) {
    if (se3) {
      graph->Add<BetweenSE3>(a, b, z3, noise);
    } else {
      graph->Add<BetweenSE2>(a, b, z2, noise);
    }
    graph->at(graph->size() - 1).set_loop_closure(true);
    wrong->insert(graph->size() - 1);
  };
  int added = 0;
  while (added < count) {
    const std::size_t i = pick(rng), j = pick(rng);
    const std::size_t group = grouped ? 5 : 1;
    if (i + group > t.poses.size() || j + group > t.poses.size()) continue;
    if ((i > j ? i - j : j - i) <= group) continue;
    SE2d z2;
    SE3d z3;
    RandomRelative(se3, rng, &z2, &z3);
    const SqrtInformation& noise = t.closures[closure(rng)]->noise();
    for (std::size_t k = 0; k < group && added < count; ++k, ++added) {
      const Key a = t.poses[i + k], b = t.poses[j + k];
      if (k == 0 || !grouped) {
        add(a, b, z2, z3, noise);
        continue;
      }
      // Consistent with the first of the cluster: (X_{i+k}^-1 X_i) z (X_j^-1 X_{j+k}).
      if (se3) {
        const SE3d zi = t.optimum.At<SE3d>(a).Inverse() * t.optimum.At<SE3d>(t.poses[i]);
        const SE3d zj = t.optimum.At<SE3d>(t.poses[j]).Inverse() * t.optimum.At<SE3d>(b);
        add(a, b, z2, zi * z3 * zj, noise);
      } else {
        const SE2d zi = t.optimum.At<SE2d>(a).Inverse() * t.optimum.At<SE2d>(t.poses[i]);
        const SE2d zj = t.optimum.At<SE2d>(t.poses[j]).Inverse() * t.optimum.At<SE2d>(b);
        add(a, b, zi * z2 * zj, z3, noise);
      }
    }
  }
}

// The factors with a loss whose final weight rho' is below 0.1 (the methods without a
// rejected set of their own).
std::vector<std::size_t> RejectedByWeight(const FactorGraph& graph, const Values& v) {
  std::vector<std::size_t> rejected;
  for (std::size_t i = 0; i < graph.size(); ++i) {
    const Factor& f = graph.at(i);
    if (f.loss() == nullptr) continue;
    double rho[3];
    f.loss()->Evaluate(f.Chi2(v), rho);
    if (rho[1] < 0.1) rejected.push_back(i);
  }
  return rejected;
}

// The sigma of "sc:SIGMA" (0 where the method is not of that form or SIGMA is not above 0).
double SwitchPriorSigma(const std::string& method) {
  if (method.compare(0, 3, "sc:") != 0) return 0;
  char* end = nullptr;
  const double sigma = std::strtod(method.c_str() + 3, &end);
  return (end != method.c_str() + 3 && *end == '\0' && std::isfinite(sigma) && sigma > 0) ? sigma : 0;
}

// Solves `graph` from `v` with one method; the closures it rejects. False where the solve
// failed; throws what the solvers throw.
bool SolveWithMethod(const std::string& method, FactorGraph* graph, Values* v, std::vector<std::size_t>* rejected,
                     OutlierBenchRow* row) {
  // From the file's start (odometry): the chordal relaxation solves every closure at once, the
  // false ones included, and starts every method ruined.
  if (method == "gnc" || method == "gnc-ls") {
    GncOptions go;
    if (method == "gnc-ls") go.start = GncStart::kLeastSquares;
    const GncSummary gs = OptimizeGnc(*graph, v, go);
    *rejected = gs.rejected;
    row->gnc_stages_max = std::max(row->gnc_stages_max, gs.stages);
    row->gnc_start_seconds += gs.start_seconds;
    row->gnc_stages_seconds += gs.stages_seconds;
    row->gnc_final_seconds += gs.final_seconds;
    return gs.usable;
  }
  if (method == "cdcs") {
    for (std::size_t i = 0; i < graph->size(); ++i) {
      Factor& f = graph->at(i);
      if (f.loop_closure()) f.set_loss(std::make_shared<DcsLoss>(Chi2Quantile(f.dim(), 0.99)));
    }
    const ChunkedSolveSummary cs = SolveInChunks(*graph, v);
    *rejected = RejectedByWeight(*graph, *v);
    return cs.usable;
  }
  if (method.compare(0, 2, "sc") == 0) {
    SwitchableOptions so;
    so.prior_sigma = method == "sc" ? 0.0 : SwitchPriorSigma(method);
    SwitchableSummary ss = OptimizeSwitchable(*graph, v, so);
    *rejected = std::move(ss.rejected);
    return ss.usable;
  }
  if (method != "none") {
    ApplyRobustRules({ParseRobustRule(method == "huber" ? "loop=huber:1" : "loop=dcs:1")}, DefaultRegistry(), graph);
  }
  const bool ok = Optimize(*graph, v).IsSolutionUsable();
  *rejected = RejectedByWeight(*graph, *v);
  return ok;
}

// The file's graph, its start, its loop closures and its optimum (the truth the methods are
// scored against).
Truth LoadTruth(const std::string& file, std::ostream& progress) {
  Truth t;
  GraphFile g = ReadGraphFile(file, DefaultRegistry());
  t.graph = std::move(g.graph);
  t.initial = std::move(g.values);
  for (Key k : t.initial.keys()) {
    if (IsPose(t.initial.TypeOf(k))) t.poses.push_back(k);
  }
  for (std::size_t i = 0; i < t.graph.size(); ++i) {
    if (t.graph.at(i).loop_closure()) t.closures.push_back(&t.graph.at(i));
  }
  if (t.closures.empty() || t.poses.size() < 20) {
    throw InvalidArgument(file + ": no loop closures (edges between non-consecutive poses) to corrupt");
  }
  t.optimum = t.initial;
  const auto t0 = std::chrono::steady_clock::now();
  Initialize(t.graph, &t.optimum, InitMethod::kChordal);
  const SolverSummary clean = Optimize(t.graph, &t.optimum);
  t.seconds = SecondsSince(t0);
  t.chi2 = clean.final_chi2;
  progress << file << ": " << t.closures.size() << " loop closures, optimum chi2 " << t.chi2 << " in " << t.seconds
           << " s\n";
  return t;
}

}  // namespace

std::vector<OutlierBenchRow> RunOutlierBench(const OutlierBenchOptions& options, std::ostream& progress) {
  for (const std::string& m : options.methods) {
    if (m != "none" && m != "huber" && m != "dcs" && m != "gnc" && m != "gnc-ls" && m != "sc" && m != "cdcs" &&
        SwitchPriorSigma(m) <= 0) {
      throw InvalidArgument(
          "unknown outlier-bench method '" + m +
          "' (use none, huber, dcs, cdcs, gnc, gnc-ls, sc, or sc:SIGMA with the switch prior's sigma above 0)");
    }
  }
  std::vector<OutlierBenchRow> rows;
  for (const std::string& file : options.files) {
    const Truth t = LoadTruth(file, progress);
    for (double rate : options.rates) {
      const int count = static_cast<int>(std::lround(rate * static_cast<double>(t.closures.size())));
      for (const std::string& method : options.methods) {
        OutlierBenchRow row;
        row.file = file.substr(file.find_last_of('/') + 1);
        row.mode = options.grouped ? "grouped" : "random";
        row.method = method;
        row.rate = rate;
        row.false_closures = count;
        row.true_closures = static_cast<int>(t.closures.size());
        row.status = "ok";
        std::vector<double> ate, chi2, time;
        for (int seed : options.seeds) {
          FactorGraph graph = t.graph;
          std::set<std::size_t> wrong;
          AddFalseClosures(t, count, options.grouped, static_cast<std::uint64_t>(seed), &graph, &wrong);
          Values v = t.initial;
          const auto s0 = std::chrono::steady_clock::now();
          std::vector<std::size_t> rejected;
          bool ok = true;
          try {
            ok = SolveWithMethod(method, &graph, &v, &rejected, &row);
          } catch (const Error& e) {
            ok = false;
            row.status = e.what();
          }
          const double seconds = SecondsSince(s0);
          if (!ok) {
            if (row.status == "ok") row.status = "a solve failed (seed " + std::to_string(seed) + ")";
            continue;
          }
          ate.push_back(AbsoluteTrajectoryError(v, t.optimum).rmse);
          chi2.push_back(t.graph.Chi2(v) / t.chi2);
          time.push_back(seconds / t.seconds);
          int hits = 0;
          for (std::size_t i : rejected) hits += wrong.count(i) != 0;
          const double precision = rejected.empty() ? (wrong.empty() ? 1 : 0) : double(hits) / rejected.size();
          const double recall = wrong.empty() ? 1 : double(hits) / wrong.size();
          row.precision_min = std::min(row.precision_min, precision);
          row.recall_min = std::min(row.recall_min, recall);
          ++row.runs;
        }
        row.ate_median = Median(ate);
        row.ate_max = ate.empty() ? std::nan("") : *std::max_element(ate.begin(), ate.end());
        row.chi2_ratio = Median(chi2);
        row.time_ratio = Median(time);
        progress << "  " << row.mode << " " << rate << " " << method << ": ATE " << row.ate_median << " m (max "
                 << row.ate_max << "), precision " << row.precision_min << ", recall " << row.recall_min;
        if (row.gnc_stages_max > 0) {
          progress << "; GNC over the seeds: start " << row.gnc_start_seconds << " s, stages " << row.gnc_stages_seconds
                   << " s (at most " << row.gnc_stages_max << " per run), final " << row.gnc_final_seconds << " s";
        }
        progress << "\n" << std::flush;
        rows.push_back(row);
      }
    }
  }
  return rows;
}

std::string FormatOutlierBenchMarkdown(const std::vector<OutlierBenchRow>& rows) {
  std::string s =
      "| file | mode | false closures | method | ATE median (max) [m] | chi2 of the true factors / optimum | "
      "precision (min) | recall (min) | time / clean solve | runs | status |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|\n";
  char buf[512];
  for (const OutlierBenchRow& r : rows) {
    std::snprintf(buf, sizeof buf,
                  "| %s | %s | %.0f%% (%d of %d true) | %s | %.3g (%.3g) | %.4g | %.3f | %.3f | %.3g | %d | %s |\n",
                  r.file.c_str(), r.mode.c_str(), 100 * r.rate, r.false_closures, r.true_closures, r.method.c_str(),
                  r.ate_median, r.ate_max, r.chi2_ratio, r.precision_min, r.recall_min, r.time_ratio, r.runs,
                  r.status.c_str());
    s += buf;
  }
  return s;
}

}  // namespace tether
