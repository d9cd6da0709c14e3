#include "tether/solvers/switchable.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <set>

#include "gauge.h"
#include "minimizer.h"
#include "tether/core/error.h"
#include "tether/core/robust_kernels.h"
#include "tether/core/timing.h"
#include "tether/factors/switchable.h"
#include "tether/solvers/optimizer.h"

namespace tether {

SwitchableOptions::SwitchableOptions() { solver.max_iterations = kMinIterations; }

void SwitchableOptions::SetSolver(const SolverOptions& s) {
  solver = s;
  solver.max_iterations = std::max(s.max_iterations, kMinIterations);
}

bool SwitchableOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  if (!(std::isfinite(prior_sigma) && prior_sigma >= 0)) {
    return fail("prior_sigma must be 0 (from inlier_probability) or a finite number above 0");
  }
  if (prior_sigma == 0 && !(inlier_probability > 0.5 && inlier_probability < 1)) {
    return fail("inlier_probability must be in (0.5, 1)");
  }
  if (!(reject_below >= 0 && reject_below <= 1)) return fail("reject_below must be in [0, 1]");
  std::string reason;
  if (!solver.IsValid(&reason)) return fail("solver: " + reason);
  return true;
}

FactorGraph WithSwitches(const FactorGraph& graph, Values* values, const SwitchableOptions& options,
                         std::vector<Key>* switch_keys) {
  if (values == nullptr) throw InvalidArgument("WithSwitches: values must not be null");
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("invalid switchable-constraint options: " + why);
  InternSwitchType();
  Key next = 0;
  for (Key k : values->keys()) next = std::max(next, k);
  std::size_t closures = 0;
  for (std::size_t i = 0; i < graph.size(); ++i) closures += graph.at(i).loop_closure() ? 1 : 0;
  if (!values->empty() && next > std::numeric_limits<Key>::max() - closures - 1) {
    throw InvalidArgument("WithSwitches: no free keys above the largest key for " + std::to_string(closures) +
                          " switches");
  }
  if (!values->empty()) ++next;
  FactorGraph out;
  std::vector<Key> keys;
  std::vector<int> dims;
  keys.reserve(closures);
  for (std::size_t i = 0; i < graph.size(); ++i) {
    const Factor& f = graph.at(i);
    if (!f.loop_closure()) {
      out.Add(f.Clone());
      continue;
    }
    const Key s = next++;
    keys.push_back(s);
    dims.push_back(f.dim());
    values->Insert(s, Switch{1.0});
    out.Add(std::make_unique<SwitchableFactor>(f.Clone(), s));
  }
  std::map<int, double> sigma_of_dim;  // from the chi2 quantile, once per dimension
  for (std::size_t k = 0; k < keys.size(); ++k) {
    if (options.prior_sigma == 0 && sigma_of_dim.count(dims[k]) == 0) {
      sigma_of_dim[dims[k]] = 1 / std::sqrt(Chi2Quantile(dims[k], options.inlier_probability));
    }
    const double sigma = options.prior_sigma > 0 ? options.prior_sigma : sigma_of_dim[dims[k]];
    out.Add(std::make_unique<SwitchPrior>(keys[k], 1.0, SqrtInformation::Isotropic(1, sigma)));
  }
  for (Key k : graph.fixed()) out.Fix(k);
  // The switch priors are one-key factors, which the solvers take as anchoring the graph: where
  // the graph itself has no anchor (nothing fixed, no one-key factor), hold its lowest-key pose
  // as the solvers would have.
  SolverSummary gauge;
  const std::set<Key> held = internal::ChooseFixed(graph, *values, &gauge);
  if (gauge.gauge_fixed_automatically) out.Fix(*held.begin());
  if (switch_keys != nullptr) *switch_keys = std::move(keys);
  return out;
}

SwitchableSummary OptimizeSwitchable(const FactorGraph& graph, Values* values, const SwitchableOptions& options) {
  if (values == nullptr) throw InvalidArgument("OptimizeSwitchable: values must not be null");
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("invalid switchable-constraint options: " + why);
  const auto t0 = std::chrono::steady_clock::now();
  SwitchableSummary r;
  r.weights.assign(graph.size(), 1.0);
  r.switches.assign(graph.size(), 1.0);
  Values work = *values;
  std::vector<Key> switches;
  const FactorGraph switched = WithSwitches(graph, &work, options, &switches);
  r.loop_closures = static_cast<int>(switches.size());
  r.solve = Optimize(switched, &work, options.solver);
  std::size_t next = 0;
  for (std::size_t i = 0; i < graph.size(); ++i) {
    if (!graph.at(i).loop_closure()) continue;
    const double s = work.At<Switch>(switches[next++]).value;
    const double psi = SwitchScale(s);
    r.switches[i] = s;
    r.weights[i] = psi * psi;
    if (r.weights[i] < options.reject_below) r.rejected.push_back(i);
  }
  // The graph's own variables back, without the switches.
  for (Key k : values->keys()) {
    double* p = values->Params(k);
    const double* q = work.Params(k);
    std::copy(q, q + AmbientDim(values->TypeOf(k)), p);
  }
  r.usable = r.solve.IsSolutionUsable();
  if (!r.usable) r.message = "the solve with switchable constraints failed: " + r.solve.message;
  if (r.usable && options.refit) {
    FactorGraph kept;
    std::size_t next_rejected = 0;
    for (std::size_t i = 0; i < graph.size(); ++i) {
      if (next_rejected < r.rejected.size() && r.rejected[next_rejected] == i) {
        ++next_rejected;
        continue;
      }
      kept.Add(graph.at(i).Clone());
    }
    for (Key k : graph.fixed()) kept.Fix(k);
    Values trial = *values;
    r.refit = Optimize(kept, &trial, options.solver);
    if (r.refit.IsSolutionUsable()) {
      *values = std::move(trial);
    } else {
      r.message = "least squares over the kept closures failed (" + r.refit.message + "); the switched solution stays";
    }
  }
  r.seconds = SecondsSince(t0);
  return r;
}

}  // namespace tether
