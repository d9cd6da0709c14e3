#include "tether/solvers/incremental_smoother.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <set>
#include <unordered_map>
#include <utility>

#include "blas_threads.h"
#include "incremental_cholesky.h"
#include "local_regions.h"
#include "one_variable.h"
#include "tether/core/error.h"
#include "tether/core/robust_kernels.h"
#include "tether/core/timing.h"
#include "tether/solvers/optimizer.h"

namespace tether {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// Moves each of the new variables `fresh` in *values to the minimum of the cost of the new
// factors that use it once, every other variable held at its value (the old ones' estimate,
// or a new one's value as refined so far): a few Gauss-Newton steps on that one variable.
// Keys in `hold` (the fixed ones, the automatic gauge) are left alone, and so is a variable
// with fewer than two such factors or one they do not determine (its information matrix
// is singular or nearly so). Returns the keys that moved.
std::vector<Key> RefineNewValues(const std::vector<const Factor*>& factors, const std::vector<Key>& fresh,
                                 const std::set<Key>& hold, Values* values) {
  std::vector<Key> moved;
  std::unordered_map<Key, std::vector<const Factor*>> uses;
  for (const Factor* f : factors) {
    for (Key k : f->keys()) {
      auto& list = uses[k];
      if (list.empty() || list.back() != f) list.push_back(f);
    }
  }
  for (Key k : fresh) {
    if (hold.count(k) || !values->Has(k)) continue;
    std::vector<const Factor*> mine;
    for (const Factor* f : uses[k]) {
      if (std::count(f->keys().begin(), f->keys().end(), k) == 1) mine.push_back(f);
    }
    if (mine.size() < 2) continue;
    const VarType type = values->TypeOf(k);
    const int d = TangentDim(type);
    std::vector<double> x(values->Params(k), values->Params(k) + AmbientDim(type)), trial(x.size());
    // The cost at p (and H and g where they are not null), or infinity where a factor cannot
    // be evaluated there.
    auto evaluate = [&](const double* p, Eigen::MatrixXd* H, Eigen::VectorXd* g) {
      return internal::OneVariableCost(mine, k, p, *values, H, g);
    };
    Eigen::MatrixXd H(d, d);
    Eigen::VectorXd g(d);
    double cost = evaluate(x.data(), nullptr, nullptr);
    bool changed = false;
    for (int it = 0; it < 5 && std::isfinite(cost); ++it) {
      H.setZero();
      g.setZero();
      if (!std::isfinite(evaluate(x.data(), &H, &g)) || !H.allFinite()) break;
      if (it == 0) {
        // Determined: every direction of the tangent space is seen by the factors.
        const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(H, Eigen::EigenvaluesOnly);
        if (eig.info() != Eigen::Success || !(eig.eigenvalues()(0) > 1e-9 * eig.eigenvalues()(d - 1))) break;
      }
      const Eigen::LLT<Eigen::MatrixXd> llt(H);
      if (llt.info() != Eigen::Success) break;
      const Eigen::VectorXd delta = -llt.solve(g);
      if (!delta.allFinite()) break;
      RetractParams(type, x.data(), delta.data(), trial.data());
      const double next = evaluate(trial.data(), nullptr, nullptr);
      if (!(next < cost)) break;
      x.swap(trial);
      changed = true;
      const bool small = next > (1 - 1e-6) * cost;
      cost = next;
      if (small) break;
    }
    if (changed) {
      std::copy(x.begin(), x.end(), values->Params(k));
      moved.push_back(k);
    }
  }
  return moved;
}

}  // namespace

SmootherOptions::SmootherOptions() {
  update.max_iterations = 10;
  local_batch.algorithm = Algorithm::kGaussNewton;
  local_batch.max_iterations = 10;
  finish.max_iterations = 100;
  finish.function_tolerance = 1e-12;
}

bool SmootherOptions::IsValid(std::string* why) const {
  std::string reason;
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(wildfire_threshold >= 0)) return fail("wildfire_threshold must be 0 or more");
  if (rounds_per_update < 1) return fail("rounds_per_update must be at least 1");
  if (!(relinearize_threshold >= 0)) return fail("relinearize_threshold must be 0 or more");
  if (!(relinearize_sigmas >= 0)) return fail("relinearize_sigmas must be 0 or more");
  if (!(iterate_ratio >= 1)) return fail("iterate_ratio must be at least 1");
  if (!(iterate_fraction >= 0 && iterate_fraction <= 1)) return fail("iterate_fraction must be in [0, 1]");
  if (!(iterate_share >= 0 && iterate_share <= 1)) return fail("iterate_share must be in [0, 1]");
  if (!(local_tolerance >= 0)) return fail("local_tolerance must be 0 or more");
  if (local_hops < 0) return fail("local_hops must be 0 or more");
  if (local_max_region < 1) return fail("local_max_region must be at least 1");
  if (!(local_batch_share >= 0 && local_batch_share <= 1)) return fail("local_batch_share must be in [0, 1]");
  if (!(local_batch_gap >= 0)) return fail("local_batch_gap must be 0 or more");
  if (!(local_batch_correction >= 0)) return fail("local_batch_correction must be 0 or more");
  if (!update.IsValid(&reason)) return fail("update: " + reason);
  if (!local_batch.IsValid(&reason)) return fail("local_batch: " + reason);
  if (!finish.IsValid(&reason)) return fail("finish: " + reason);
  if (!covariance.IsValid(&reason)) return fail("covariance: " + reason);
  return true;
}

// The smoother's bookkeeping around the factor: keys and handles to the factor's indices, the
// linearisation point theta of every variable (the estimate is theta (+) delta), the factors'
// uses of every variable (for the gauge and for erasing variables), and the variables whose
// step has grown beyond the threshold.
struct IncrementalSmoother::State {
  internal::IncrementalCholesky engine;
  internal::LocalRegions local;        // SmootherMode::kLocal: the factors of every variable
  int since_batch = 0;                 // kLocal: updates since the last batch solve,
  double gain_since_batch = 0;         // the edge gains the local solves left since then,
  double chi2_at_batch = 0;            // and chi2 at its end,
  std::size_t variables_at_batch = 0;  // and the variables then
  std::unordered_map<Key, int> index_of;
  std::vector<Key> key_of;
  std::vector<VarType> type_of;
  std::vector<std::vector<double>> theta;  // empty for removed variables
  std::unordered_map<FactorId, int> slot_of;
  std::vector<const Factor*> factor_of_slot;  // null for removed factors
  std::unordered_map<Key, int> uses;
  std::set<Key> used_poses;  // poses some factor uses: the lowest is the automatic gauge
  int unary = 0;             // uses by factors that anchor the graph (priors): no automatic gauge then
  std::set<Key> constants;
  std::vector<int> pending;  // variables to re-linearise
  std::vector<char> is_pending;
  std::vector<int> near;              // variables whose step is beyond iterate_fraction of the thresholds
  std::vector<const double*> params;  // scratch for Linearize
  std::vector<double*> jacobians;

  void AddVariable(Key k, VarType type, const double* p) {
    const int v = engine.AddVariable(TangentDim(type));
    index_of[k] = v;
    key_of.push_back(k);
    type_of.push_back(type);
    theta.emplace_back(p, p + AmbientDim(type));
    is_pending.push_back(0);
  }
  // A new variable's linearisation point, before any factor of it is evaluated.
  void SetTheta(Key k, const double* p) {
    std::vector<double>& t = theta[index_of.at(k)];
    std::copy(p, p + t.size(), t.begin());
  }
  void Use(Key k, bool unary_factor, VarType type) {
    if (uses[k]++ == 0 && IsPose(type)) used_poses.insert(k);
    if (unary_factor) ++unary;
  }
  void Unuse(Key k, bool unary_factor) {
    if (--uses[k] == 0) used_poses.erase(k);
    if (unary_factor) --unary;
  }
  void RemoveVariable(Key k) {
    const int v = index_of.at(k);
    engine.RemoveVariable(v);
    index_of.erase(k);
    theta[v].clear();
    theta[v].shrink_to_fit();
    constants.erase(k);
  }
  bool Alive(int v) const { return !theta[v].empty(); }

  // Evaluates a factor at the linearisation point of its variables (and marks them touched).
  bool Linearize(int slot) {
    const Factor* f = factor_of_slot[static_cast<std::size_t>(slot)];
    const std::vector<int>& vars = engine.vars_of(slot);
    params.resize(vars.size());
    jacobians.resize(vars.size());
    for (std::size_t k = 0; k < vars.size(); ++k) {
      params[k] = theta[vars[k]].data();
      jacobians[k] = engine.IsConstant(vars[k]) ? nullptr : engine.JacobianBlock(slot, static_cast<int>(k));
    }
    double* r = engine.Residual(slot);
    engine.Touch(slot);
    if (!f->Linearize(params.data(), r, jacobians.data())) return false;
    double s = 0;
    for (int i = 0; i < f->dim(); ++i) {
      if (!std::isfinite(r[i])) return false;
      s += r[i] * r[i];
    }
    // A robust loss: residual and Jacobians weighted by sqrt(rho'(s)) at theta, as Optimize
    // does; the weight is fixed until the factor is re-linearised.
    const double w = RobustWeight(f->loss(), s);
    if (w != 1) {
      for (int i = 0; i < f->dim(); ++i) r[i] *= w;
      for (std::size_t k = 0; k < vars.size(); ++k) {
        if (jacobians[k] == nullptr) continue;
        const int n = f->dim() * engine.dim(vars[k]);
        for (int i = 0; i < n; ++i) jacobians[k][i] *= w;
      }
    }
    return true;
  }

  // Moves the linearisation point of variable v to the estimate (theta (+) delta) and marks
  // its factors for re-linearisation in *slots.
  void Fold(int v, const Values& estimate, std::vector<int>* slots) {
    const double* x = estimate.Params(key_of[v]);
    std::copy(x, x + theta[v].size(), theta[v].begin());
    engine.ClearDelta(v);
    for (int f : engine.factors_of(v)) slots->push_back(f);
  }

  bool LinearizeAll(std::vector<int>* slots) {
    std::sort(slots->begin(), slots->end());
    slots->erase(std::unique(slots->begin(), slots->end()), slots->end());
    bool ok = true;
    for (int f : *slots) ok = Linearize(f) && ok;
    return ok;
  }

  // The size of v's step against the re-linearisation thresholds (beyond one: re-linearise):
  // the larger of the step over relinearize_threshold, and the step in standard deviations
  // of the information v's own factors give it over relinearize_sigmas.
  double Step(int v, const SmootherOptions& o) const {
    const Eigen::VectorXd& d = engine.delta(v);
    const Eigen::VectorXd& s = engine.scale(v);
    // x over a threshold t; where t is 0, any step at all is too large.
    auto over = [](double x, double t) { return t > 0 ? x / t : (x > 0 ? kInfinity : 0.0); };
    double step = over(d.lpNorm<Eigen::Infinity>(), o.relinearize_threshold);
    if (s.size() == d.size())
      step = std::max(step, over(d.cwiseProduct(s).lpNorm<Eigen::Infinity>(), o.relinearize_sigmas));
    return step;
  }

  // The variables near the thresholds become pending, before another round of an update.
  void PendNear() {
    for (int v : near) {
      if (!is_pending[v]) {
        is_pending[v] = 1;
        pending.push_back(v);
      }
    }
    near.clear();
  }

  // The pending variables get their linearisation point moved and their factors re-evaluated.
  bool Relinearize(const Values& estimate) {
    std::vector<int> slots;
    for (int v : pending) {
      is_pending[v] = 0;
      if (Alive(v)) Fold(v, estimate, &slots);
    }
    pending.clear();
    return LinearizeAll(&slots);
  }

  // The graph's fixed set, or where it fixes nothing and no prior anchors it, the lowest-key
  // pose some factor uses (as Optimize chooses). A variable that changes sides has its step
  // folded into its linearisation point first, so that its estimate stays where it is.
  // The variables held constant: the graph's fixed set, or else (no prior either) the
  // lowest pose, the automatic gauge.
  std::set<Key> Held(const FactorGraph& graph) const {
    std::set<Key> held = graph.fixed();
    if (held.empty() && unary == 0 && !used_poses.empty()) held.insert(*used_poses.begin());
    return held;
  }

  bool UpdateConstants(const FactorGraph& graph, const Values& estimate) {
    const std::set<Key> want = Held(graph);
    if (want == constants) return true;
    std::vector<int> slots;
    auto flip = [&](Key k, bool constant) {
      const int v = index_of.at(k);
      Fold(v, estimate, &slots);
      engine.SetConstant(v, constant);
    };
    for (Key k : constants) {
      if (!want.count(k) && index_of.count(k)) flip(k, false);
    }
    for (Key k : want) {
      if (!constants.count(k)) flip(k, true);
    }
    constants = want;
    return LinearizeAll(&slots);
  }

  // The estimate of every variable whose step changed; the ones beyond the threshold become
  // pending, and *largest is the largest Step among them (0 where none); the ones beyond
  // iterate_fraction of it are listed in near. Nothing changes where a step is not finite.
  bool Apply(const std::vector<int>& changed, const SmootherOptions& o, Values* estimate, double* largest,
             std::string* why) {
    *largest = 0;
    for (int v : changed) {
      if (Alive(v) && !engine.delta(v).allFinite()) {
        *why = "the step of " + KeyToString(key_of[v]) + " is not finite";
        return false;
      }
    }
    for (int v : changed) {
      if (!Alive(v)) continue;
      const Eigen::VectorXd& d = engine.delta(v);
      RetractParams(type_of[v], theta[v].data(), d.data(), estimate->Params(key_of[v]));
      const double step = Step(v, o);
      if (step > 1 && !is_pending[v]) {
        is_pending[v] = 1;
        pending.push_back(v);
        *largest = std::max(*largest, step);
      } else if (step > o.iterate_fraction && !is_pending[v]) {
        near.push_back(v);
      }
    }
    return true;
  }

  // Linearisation point = estimate everywhere, every factor re-evaluated, and the whole factor
  // rebuilt at the next solve (after Finish() or a failure).
  void Reset(const Values& estimate) {
    std::vector<int> slots;
    for (std::size_t v = 0; v < theta.size(); ++v) {
      if (Alive(static_cast<int>(v))) Fold(static_cast<int>(v), estimate, &slots);
      is_pending[v] = 0;
    }
    pending.clear();
    LinearizeAll(&slots);
    engine.RequestFullRefactor();
  }
};

IncrementalSmoother::IncrementalSmoother(const SmootherOptions& options)
    : options_(options), state_(std::make_unique<State>()) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument("invalid smoother options: " + why);
}

IncrementalSmoother::~IncrementalSmoother() = default;

SmootherUpdate IncrementalSmoother::Update(FactorGraph new_factors, Values new_values,
                                           std::vector<FactorId> factors_to_remove) {
  const auto t0 = std::chrono::steady_clock::now();
  // The update runs on the caller's thread, BLAS kernels included: its fronts are small, and
  // a threaded BLAS's idle threads spinning between them cost more than they give.
  internal::ScopedBlasThreads one_blas_thread(1);

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
  // Each new factor once at the values it will start from, with its Jacobians: a factor that
  // throws there (a user's factor raising) throws here, while nothing has changed yet.
  {
    std::vector<const double*> params;
    Eigen::VectorXd error;
    std::vector<Eigen::MatrixXd> jacobians;
    std::vector<double*> jacobian_ptrs;
    for (std::size_t i = 0; i < new_factors.size(); ++i) {
      const Factor& f = new_factors.at(i);
      const std::vector<VarType> types = f.variable_types();
      params.clear();
      jacobians.clear();
      jacobian_ptrs.clear();
      for (Key k : f.keys()) params.push_back(new_values.Has(k) ? new_values.Params(k) : estimate_.Params(k));
      error.resize(f.residual_dim());
      for (VarType t : types) jacobians.emplace_back(f.residual_dim(), TangentDim(t));
      for (Eigen::MatrixXd& j : jacobians) jacobian_ptrs.push_back(j.data());
      f.Evaluate(params.data(), error.data(), jacobian_ptrs.data());
    }
  }

  // The changes. Nothing below throws for bad input any more.
  SmootherUpdate u;
  State& st = *state_;
  marginals_.reset();
  if (options_.compute_chi2) {
    // Of the graph after the update at the previous estimate plus the new values.
    u.chi2_before = 0;
    for (const auto& f : graph_.factors()) u.chi2_before += f->Chi2(estimate_);
    Values with_new = estimate_;
    for (Key k : new_values.keys()) with_new.InsertParams(k, new_values.TypeOf(k), new_values.Params(k));
    for (std::size_t i = 0; i < new_factors.size(); ++i) u.chi2_before += new_factors.at(i).Chi2(with_new);
    for (FactorId id : factors_to_remove) {
      std::size_t index = 0;
      graph_.IndexOf(id, &index);
      u.chi2_before -= graph_.at(index).Chi2(estimate_);
    }
  }
  if (options_.mode == SmootherMode::kLocal) {
    UpdateLocal(std::move(new_factors), std::move(new_values), factors_to_remove, &u);
    if (!options_.compute_chi2) u.chi2_before = u.chi2_after = std::nan("");
    u.seconds = SecondsSince(t0);
    return u;
  }
  std::vector<Key> touched;  // variables of the removed factors
  for (FactorId id : factors_to_remove) {
    std::size_t index = 0;
    graph_.IndexOf(id, &index);
    for (Key k : graph_.at(index).keys()) {
      st.Unuse(k, graph_.at(index).anchors());
      touched.push_back(k);
    }
    auto slot = st.slot_of.find(id);
    st.engine.RemoveFactor(slot->second);
    st.factor_of_slot[slot->second] = nullptr;
    st.slot_of.erase(slot);
    graph_.Remove(id);
    ++u.factors_removed;
  }
  for (Key k : new_values.keys()) {
    const VarType type = new_values.TypeOf(k);
    estimate_.InsertParams(k, type, new_values.Params(k));
    st.AddVariable(k, type, new_values.Params(k));
    ++u.variables_added;
  }
  u.new_factor_ids.reserve(new_factors.size());
  std::vector<int> new_slots;
  std::vector<const Factor*> added;
  for (std::size_t i = 0; i < new_factors.size(); ++i) {
    std::unique_ptr<Factor> f = new_factors.at(i).Clone();
    const Factor* raw = f.get();
    std::vector<int> vars;
    for (Key k : f->keys()) {
      st.Use(k, f->anchors(), estimate_.TypeOf(k));
      vars.push_back(st.index_of.at(k));
    }
    added.push_back(raw);
    const FactorId id = graph_.Add(std::move(f));
    const int slot = st.engine.AddFactor(vars, raw->dim());
    if (st.factor_of_slot.size() <= static_cast<std::size_t>(slot)) st.factor_of_slot.resize(slot + 1, nullptr);
    st.factor_of_slot[slot] = raw;
    st.slot_of[id] = slot;
    for (int v : vars) st.engine.MarkRecent(v);
    new_slots.push_back(slot);
    u.new_factor_ids.push_back(id);
    ++u.factors_added;
  }
  for (Key k : new_factors.fixed()) graph_.Fix(k);
  u.variables_removed += EraseUnused(&touched);
  if (options_.refine_new_values && refine_ && !new_values.empty()) {
    // Not the variables held constant (fixed, or the automatic gauge): they stay as given.
    for (Key k : RefineNewValues(added, new_values.keys(), st.Held(graph_), &estimate_)) {
      st.SetTheta(k, estimate_.Params(k));
    }
  }
  std::string why;
  const auto t_lin = std::chrono::steady_clock::now();
  // The constant variables: the graph's fixed set, or the automatic gauge.
  bool ok = st.UpdateConstants(graph_, estimate_);
  for (int slot : new_slots) ok = st.Linearize(slot) && ok;
  u.linearize_seconds += SecondsSince(t_lin);
  if (!ok) why = "a factor cannot be evaluated at its variables' values";

  if (graph_.empty()) {
    u.chi2_after = 0;
  } else {
    u.solved = true;
    for (int round = 0; ok && round < options_.rounds_per_update; ++round) {
      // Move the linearisation points of the variables whose step is beyond the threshold.
      const auto t0 = std::chrono::steady_clock::now();
      u.relinearized += static_cast<int>(st.pending.size());
      ok = st.Relinearize(estimate_) && ok;
      u.linearize_seconds += SecondsSince(t0);
      if (!ok) {
        why = "a factor cannot be evaluated at its variables' values";
        break;
      }
      std::vector<int> changed;
      st.engine.SetMethod(options_.factorization == SmootherFactorization::kLeftLooking
                              ? internal::IncrementalCholesky::Method::kLeftLooking
                          : options_.factorization == SmootherFactorization::kMultifrontal
                              ? internal::IncrementalCholesky::Method::kMultifrontal
                              : internal::IncrementalCholesky::Method::kAuto);
      if (!st.engine.Solve(options_.wildfire_threshold, &changed, &why)) {
        ok = false;
        break;
      }
      const internal::IncrementalCholesky::Stats& es = st.engine.stats();
      u.factorize_seconds += es.factor_seconds;
      u.solve_seconds += es.back_seconds;
      ++u.iterations;
      u.structure_rebuilt = u.structure_rebuilt || es.full;
      u.affected_columns += es.affected;
      u.back_substituted += es.back_substituted;
      double largest = 0;
      if (!st.Apply(changed, options_, &estimate_, &largest, &why)) {
        ok = false;
        break;
      }
      // Another round where a step is still large (the linearisation is far off there), or
      // where many steps are too large (a large part of the map moved).
      const bool many =
          static_cast<double>(st.pending.size()) > options_.iterate_share * static_cast<double>(estimate_.size());
      if (!(largest > options_.iterate_ratio) && !many) {
        st.near.clear();
        break;
      }
      // Solving again: the steps just below the thresholds go too (iterate_fraction).
      st.PendNear();
    }
    st.near.clear();
    if (ok) {
      u.status = SolverStatus::kConverged;
      u.chi2_after = options_.compute_chi2 ? graph_.Chi2(estimate_) : std::nan("");
    } else {
      // The incremental factorisation failed: solve in batch, then start over from there.
      u.fell_back = true;
      const SolverSummary s = Optimize(graph_, &estimate_, options_.update);
      u.status = s.status;
      u.message = "the incremental solve failed (" + why + "); solved in batch: " + s.message;
      u.chi2_after = s.final_chi2;
      st.Reset(estimate_);
    }
  }
  if (!options_.compute_chi2) u.chi2_before = u.chi2_after = std::nan("");
  u.seconds = SecondsSince(t0);
  return u;
}

SmootherUpdate IncrementalSmoother::Restart(FactorGraph graph, Values values) {
  IncrementalSmoother fresh(options_);
  fresh.refine_ = false;
  SmootherUpdate u = fresh.Update(std::move(graph), std::move(values));
  std::swap(graph_, fresh.graph_);
  std::swap(estimate_, fresh.estimate_);
  std::swap(state_, fresh.state_);
  finish_summary_ = SolverSummary{};
  marginals_.reset();
  return u;
}

int IncrementalSmoother::EraseUnused(std::vector<Key>* keys) {
  State& st = *state_;
  std::sort(keys->begin(), keys->end());
  keys->erase(std::unique(keys->begin(), keys->end()), keys->end());
  int erased = 0;
  for (Key k : *keys) {
    auto it = st.uses.find(k);
    if (it == st.uses.end() || it->second != 0) continue;
    st.uses.erase(it);
    graph_.Unfix(k);
    if (options_.mode == SmootherMode::kFactor) st.RemoveVariable(k);
    if (estimate_.Erase(k)) ++erased;
  }
  return erased;
}

void IncrementalSmoother::UpdateLocal(FactorGraph new_factors, Values new_values,
                                      const std::vector<FactorId>& factors_to_remove, SmootherUpdate* u) {
  State& st = *state_;
  std::vector<Key> seeds;  // the variables of the removed and the new factors, and the new ones
  for (FactorId id : factors_to_remove) {
    std::size_t index = 0;
    graph_.IndexOf(id, &index);
    const Factor& f = graph_.at(index);
    st.local.Remove(id, &f);
    for (Key k : f.keys()) {
      st.Unuse(k, f.anchors());
      seeds.push_back(k);
    }
    graph_.Remove(id);
    ++u->factors_removed;
  }
  for (Key k : new_values.keys()) {
    estimate_.InsertParams(k, new_values.TypeOf(k), new_values.Params(k));
    seeds.push_back(k);
    ++u->variables_added;
  }
  std::vector<const Factor*> added;
  for (std::size_t i = 0; i < new_factors.size(); ++i) {
    std::unique_ptr<Factor> f = new_factors.at(i).Clone();
    const Factor* raw = f.get();
    for (Key k : raw->keys()) {
      st.Use(k, raw->anchors(), estimate_.TypeOf(k));
      seeds.push_back(k);
    }
    const FactorId id = graph_.Add(std::move(f));
    st.local.Add(id, raw);
    added.push_back(raw);
    u->new_factor_ids.push_back(id);
    ++u->factors_added;
  }
  for (Key k : new_factors.fixed()) graph_.Fix(k);
  u->variables_removed += EraseUnused(&seeds);
  const std::set<Key> held = st.Held(graph_);
  if (options_.refine_new_values && refine_ && !new_values.empty())
    RefineNewValues(added, new_values.keys(), held, &estimate_);
  if (graph_.empty()) {
    u->chi2_after = 0;
    return;
  }
  u->solved = true;
  ++st.since_batch;
  bool batch = st.since_batch >= std::max(1.0, options_.local_batch_share * static_cast<double>(estimate_.size())) ||
               held != st.constants;
  st.constants = held;
  if (!batch) {
    internal::LocalRegionOptions lo;
    const double per_variable =
        std::max(st.chi2_at_batch / static_cast<double>(std::max<std::size_t>(st.variables_at_batch, 1)), 1e-6);
    lo.tolerance = options_.local_tolerance * per_variable;
    lo.hops = options_.local_hops;
    lo.max_region = options_.local_max_region;
    const auto t_solve = std::chrono::steady_clock::now();
    const internal::LocalRegions::Result r = st.local.Solve(seeds, held, lo, &estimate_);
    u->solve_seconds += SecondsSince(t_solve);
    u->region = r.region;
    u->iterations = r.iterations;
    if (!r.ok) {
      u->fell_back = true;
      u->message = "the local solve failed (a factor cannot be evaluated, or a step is not finite); solved in batch";
    }
    st.gain_since_batch += r.edge_gain;
    // Shares of chi2 at the last batch solve, with the tolerance's floor of 1e-6 a variable
    // (chi2 is 0 while the graph has no loop, where every gain is rounding).
    const double scale = per_variable * static_cast<double>(std::max<std::size_t>(st.variables_at_batch, 1));
    batch = r.capped || !r.ok || st.gain_since_batch > options_.local_batch_gap * scale ||
            r.gained > options_.local_batch_correction * scale;
  }
  if (batch) {
    // Gauss-Newton from an estimate this near the optimum; Levenberg-Marquardt (options.update)
    // where that fails.
    SolverSummary s = Optimize(graph_, &estimate_, options_.local_batch);
    if (!s.IsSolutionUsable()) s = Optimize(graph_, &estimate_, options_.update);
    u->batch = true;
    u->region = 0;
    u->iterations = s.iterations;
    u->status = s.status;
    if (u->message.empty() && s.status != SolverStatus::kConverged) u->message = s.message;
    u->chi2_after = s.final_chi2;
    st.since_batch = 0;
    st.gain_since_batch = 0;
    st.chi2_at_batch = s.final_chi2;
    st.variables_at_batch = estimate_.size();
  } else {
    u->status = SolverStatus::kConverged;
    u->chi2_after = options_.compute_chi2 ? graph_.Chi2(estimate_) : std::nan("");
  }
}

Eigen::MatrixXd IncrementalSmoother::Marginal(Key key) const {
  if (options_.marginal_from_factor && options_.mode == SmootherMode::kFactor) {
    const auto it = state_->index_of.find(key);
    Eigen::MatrixXd cov;
    if (it != state_->index_of.end() && state_->engine.PathMarginal(it->second, 32, &cov)) return cov;
  }
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
  if (options_.mode == SmootherMode::kLocal) {
    // Gauss-Newton to convergence first: from the local mode's estimate Levenberg-Marquardt's
    // damping can crawl along a flat valley (ais2klinik: 100 iterations, 1.3e-5 short of the
    // optimum; Gauss-Newton: 4). options.finish then confirms, or takes over where it failed.
    SolverOptions gn = options_.finish;
    gn.algorithm = Algorithm::kGaussNewton;
    Optimize(graph_, &estimate_, gn);
  }
  finish_summary_ = Optimize(graph_, &estimate_, options_.finish);
  if (options_.mode == SmootherMode::kFactor) state_->Reset(estimate_);
  return estimate_;
}

}  // namespace tether
