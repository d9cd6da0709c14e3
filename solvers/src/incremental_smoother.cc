#include "tether/solvers/incremental_smoother.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>
#include <utility>

#include "tether/core/error.h"
#include "tether/solvers/optimizer.h"

namespace tether {

namespace {

double SecondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

SmootherOptions::SmootherOptions() {
  update.max_iterations = 10;
  update.function_tolerance = 1e-6;
  finish.max_iterations = 100;
  finish.function_tolerance = 1e-12;
}

bool SmootherOptions::IsValid(std::string* why) const {
  std::string reason;
  if (!update.IsValid(&reason)) {
    if (why) *why = "update: " + reason;
    return false;
  }
  if (!finish.IsValid(&reason)) {
    if (why) *why = "finish: " + reason;
    return false;
  }
  if (std::isnan(skip_solve_chi2)) {
    if (why) *why = "skip_solve_chi2 is not a number";
    return false;
  }
  if (!covariance.IsValid(&reason)) {
    if (why) *why = "covariance: " + reason;
    return false;
  }
  return true;
}

IncrementalSmoother::IncrementalSmoother(const SmootherOptions& options) : options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument("invalid smoother options: " + why);
}

IncrementalSmoother::~IncrementalSmoother() = default;

SmootherUpdate IncrementalSmoother::Update(FactorGraph new_factors, Values new_values,
                                           std::vector<FactorId> factors_to_remove) {
  const auto t0 = std::chrono::steady_clock::now();

  // Every check comes first: an invalid update throws before anything changes.
  std::set<FactorId> removing;
  for (FactorId id : factors_to_remove) {
    std::size_t index = 0;
    if (!graph_.IndexOf(id, &index)) {
      throw InvalidArgument("cannot remove factor " + std::to_string(id) +
                            ": the smoother has no factor with that handle");
    }
    if (!removing.insert(id).second) {
      throw InvalidArgument("factor " + std::to_string(id) + " is listed twice for removal");
    }
  }
  for (Key k : new_values.keys()) {
    if (estimate_.Has(k)) {
      throw InvalidArgument("new value " + KeyToString(k) + ": the smoother already has a variable with that key");
    }
  }
  // The type of `k` after the update, or false where it will have no value.
  auto type_of = [&](Key k, VarType* type) {
    if (new_values.Has(k)) {
      *type = new_values.TypeOf(k);
      return true;
    }
    if (estimate_.Has(k)) {
      *type = estimate_.TypeOf(k);
      return true;
    }
    return false;
  };
  for (std::size_t i = 0; i < new_factors.size(); ++i) {
    const Factor& f = new_factors.at(i);
    f.CheckShape();
    const std::vector<VarType> types = f.variable_types();
    for (std::size_t j = 0; j < f.keys().size(); ++j) {
      VarType type{};
      if (!type_of(f.keys()[j], &type)) {
        throw InvalidArgument("new factor " + std::to_string(i) + " (" + f.Describe() + ") refers to " +
                              KeyToString(f.keys()[j]) + ", which has no value; add its value in the same update");
      }
      if (type != types[j]) {
        throw InvalidArgument("new factor " + std::to_string(i) + " (" + f.Describe() + ") takes a " +
                              std::string(ToString(types[j])) + " as " + KeyToString(f.keys()[j]) + ", which is a " +
                              std::string(ToString(type)));
      }
    }
  }
  for (Key k : new_factors.fixed()) {
    VarType type{};
    if (!type_of(k, &type)) throw InvalidArgument("cannot fix " + KeyToString(k) + ": it has no value");
  }

  // The changes. Nothing below throws for bad input any more.
  SmootherUpdate u;
  marginals_.reset();
  std::vector<Key> touched;  // variables of the removed factors
  for (FactorId id : factors_to_remove) {
    std::size_t index = 0;
    graph_.IndexOf(id, &index);
    for (Key k : graph_.at(index).keys()) {
      --uses_[k];
      touched.push_back(k);
    }
    graph_.Remove(id);
    ++u.factors_removed;
  }
  for (Key k : new_values.keys()) {
    estimate_.InsertParams(k, new_values.TypeOf(k), new_values.Params(k));
    ++u.variables_added;
  }
  u.new_factor_ids.reserve(new_factors.size());
  for (std::size_t i = 0; i < new_factors.size(); ++i) {
    std::unique_ptr<Factor> f = new_factors.at(i).Clone();
    for (Key k : f->keys()) ++uses_[k];
    u.new_factor_ids.push_back(graph_.Add(std::move(f)));
    ++u.factors_added;
  }
  for (Key k : new_factors.fixed()) graph_.Fix(k);
  // Variables whose last factor went: out of the estimate (they would be held forever).
  std::sort(touched.begin(), touched.end());
  touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
  for (Key k : touched) {
    auto it = uses_.find(k);
    if (it != uses_.end() && it->second == 0) {
      uses_.erase(it);
      graph_.Unfix(k);
      if (estimate_.Erase(k)) ++u.variables_removed;
    }
  }

  // New factors with zero error leave a stationary point stationary: no solve.
  if (factors_to_remove.empty() && converged_ && options_.skip_solve_chi2 >= 0) {
    double added = 0;
    for (std::size_t i = 0; i < new_factors.size() && added <= options_.skip_solve_chi2; ++i) {
      added += new_factors.at(i).Chi2(estimate_);
    }
    if (added <= options_.skip_solve_chi2) {
      u.skipped = true;
      chi2_ += added;
      u.chi2_before = u.chi2_after = chi2_;
      u.seconds = SecondsSince(t0);
      return u;
    }
  }
  if (graph_.empty()) {
    chi2_ = 0;
    converged_ = true;
  } else {
    const SolverSummary s = Optimize(graph_, &estimate_, options_.update);
    u.solved = true;
    u.structure_rebuilt = true;
    u.status = s.status;
    u.message = s.message;
    u.iterations = s.iterations;
    u.chi2_before = s.initial_chi2;
    u.chi2_after = s.final_chi2;
    u.setup_seconds = s.setup_seconds;
    u.linearize_seconds = s.linearize_seconds;
    u.factorize_seconds = s.factorize_seconds;
    u.solve_seconds = s.solve_seconds;
    chi2_ = s.final_chi2;
    converged_ = s.status == SolverStatus::kConverged;
  }
  u.seconds = SecondsSince(t0);
  return u;
}

Eigen::MatrixXd IncrementalSmoother::Marginal(Key key) const {
  if (!marginals_) marginals_ = std::make_unique<Marginals>(graph_, estimate_, options_.covariance);
  return marginals_->Marginal(key);
}

const Values& IncrementalSmoother::Finish() {
  marginals_.reset();
  if (graph_.empty()) {
    finish_summary_ = SolverSummary{};
    finish_summary_.status = SolverStatus::kConverged;
    finish_summary_.message = "nothing to optimise: the graph has no factor";
    return estimate_;
  }
  finish_summary_ = Optimize(graph_, &estimate_, options_.finish);
  chi2_ = finish_summary_.final_chi2;
  converged_ = finish_summary_.status == SolverStatus::kConverged;
  return estimate_;
}

}  // namespace tether
