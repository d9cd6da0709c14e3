#include "tether/solvers/ceres_adapter.h"

#include <ceres/iteration_callback.h>
#include <ceres/solver.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <limits>
#include <memory>
#include <thread>
#include <type_traits>
#include <utility>

#include "backend_functions.h"
#include "gauge.h"
#include "serial_openmp.h"
#include "tether/core/error.h"
#include "tether/core/timing.h"
#include "tether/solvers/ceres_problem.h"

namespace tether {

namespace {

using Clock = std::chrono::steady_clock;

// Ceres' evaluation thread count: SolverOptions::num_threads where SolverOptions has such a
// field (<= 0: one per hardware thread), otherwise 1. Detected at compile time so that this
// file needs no change when the field is added or removed.
template <typename O, typename = void>
struct HasNumThreads : std::false_type {};
template <typename O>
struct HasNumThreads<O, std::void_t<decltype(std::declval<const O&>().num_threads)>> : std::true_type {};

template <typename O>
int NumThreads(const O& options) {
  if constexpr (HasNumThreads<O>::value) {
    const int n = static_cast<int>(options.num_threads);
    return n > 0 ? n : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  } else {
    (void)options;
    return 1;
  }
}

// Checks the start as the native solver does: a finite chi2, and finite Jacobians with respect
// to the free variables. Returns an empty string when it is fine, otherwise why not.
std::string CheckStart(const FactorGraph& graph, const Values& values, const CeresProblem& problem) {
  std::vector<double> jac, r;
  std::vector<double*> ptrs;
  for (std::size_t fi = 0; fi < graph.size(); ++fi) {
    const Factor& f = graph.at(fi);
    const std::vector<VarType> types = f.variable_types();
    const std::vector<const double*> p = f.GatherParams(values);
    std::size_t total = 0;
    for (VarType t : types) total += static_cast<std::size_t>(f.dim()) * TangentDim(t);
    jac.assign(total, 0.0);
    r.assign(static_cast<std::size_t>(f.dim()), 0.0);
    ptrs.resize(types.size());
    std::size_t off = 0;
    for (std::size_t k = 0; k < types.size(); ++k) {
      ptrs[k] = problem.IsConstant(f.keys()[k]) ? nullptr : jac.data() + off;
      off += static_cast<std::size_t>(f.dim()) * TangentDim(types[k]);
    }
    // Built only where something is wrong: most solves find nothing.
    const auto where = [&] { return "factor " + std::to_string(fi) + " (" + f.Describe() + ")"; };
    const bool ok = f.Linearize(p.data(), r.data(), ptrs.data());
    if (!ok || !std::all_of(r.begin(), r.end(), [](double v) { return std::isfinite(v); })) {
      return "chi2 at the initial values is not finite: " + where() +
             (ok ? " has a non-finite error" : " fails to evaluate") + "; check the initial values and measurements";
    }
    for (std::size_t k = 0; k < types.size(); ++k) {
      if (ptrs[k] == nullptr) continue;
      for (int i = 0; i < f.dim() * TangentDim(types[k]); ++i) {
        if (!std::isfinite(ptrs[k][i])) {
          return "the Jacobian at the initial values is not finite: " + where() +
                 " has a non-finite Jacobian with respect to " + KeyToString(f.keys()[k]) +
                 "; check the initial values";
        }
      }
    }
  }
  return "";
}

// Turns Ceres' iterations into tether's IterationSummary rows.
class CallbackBridge : public ceres::IterationCallback {
 public:
  CallbackBridge(SolverSummary* s, const SolverOptions& options, const CeresProblem& problem, double initial_radius,
                 Clock::time_point t0)
      : s_(s), options_(options), problem_(problem), radius_(initial_radius), t0_(t0) {}

  ceres::CallbackReturnType operator()(const ceres::IterationSummary& c) override {
    IterationSummary it;
    it.iteration = c.iteration;
    const double offset = problem_.keyless_chi2();
    it.chi2 = 2.0 * c.cost + offset;
    it.lambda = 1.0 / radius_;  // the radius this step was computed with
    radius_ = c.trust_region_radius;
    if (c.iteration > 0) {
      // cost_change is the cost before the step minus the cost of the tried point; `cost` is
      // the cost after the iteration (the new point if accepted, the old one if not).
      const double before = c.step_is_successful ? c.cost + c.cost_change : c.cost;
      const double chi2_before = 2.0 * before + offset;
      it.relative_decrease = chi2_before > 0 ? 2.0 * c.cost_change / chi2_before : 0.0;
      it.step_norm = c.step_norm;
      it.accepted = c.step_is_successful;
    }
    it.seconds = SecondsSince(t0_);
    s_->log.push_back(it);
    if (options_.callback) options_.callback(it);
    // A factor threw: stop, and report it (Ceres only sees failed evaluations).
    if (problem_.errors().any()) return ceres::SOLVER_ABORT;
    if (options_.keep_going && !options_.keep_going(it)) {
      stopped_after_ = it.iteration;
      return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
    }
    return ceres::SOLVER_CONTINUE;
  }
  /// The iteration after which keep_going returned false (-1: it did not).
  int stopped_after() const { return stopped_after_; }

 private:
  SolverSummary* s_;
  const SolverOptions& options_;
  const CeresProblem& problem_;
  double radius_;
  Clock::time_point t0_;
  int stopped_after_ = -1;
};

// Ceres' LM over SPARSE_NORMAL_CHOLESKY with tether's stopping rules and damping (as a
// trust region, lambda = 1 / radius; see ceres_adapter.h).
ceres::Solver::Options CeresOptions(const SolverOptions& options, double initial_radius) {
  ceres::Solver::Options co;
  co.minimizer_type = ceres::TRUST_REGION;
  co.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  co.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  co.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  co.max_num_iterations = options.max_iterations;
  co.function_tolerance = options.function_tolerance;
  co.gradient_tolerance = options.gradient_tolerance;
  co.parameter_tolerance = options.parameter_tolerance;
  if (options.max_seconds > 0) co.max_solver_time_in_seconds = options.max_seconds;
  co.initial_trust_region_radius = initial_radius;
  co.max_trust_region_radius = 1.0 / options.lm.min_lambda;
  co.min_trust_region_radius = 1.0 / options.lm.max_lambda;
  co.num_threads = NumThreads(options);
  co.logging_type = ceres::SILENT;
  co.minimizer_progress_to_stdout = false;
  return co;
}

// Status and message from Ceres' termination type; true where the values are usable.
bool MapTermination(const ceres::Solver::Summary& cs, const CeresProblem& problem, const SolverOptions& options,
                    SolverSummary* summary) {
  SolverSummary& s = *summary;
  bool usable = false;
  switch (cs.termination_type) {
    case ceres::CONVERGENCE:
    case ceres::USER_SUCCESS:
      s.status = SolverStatus::kConverged;
      s.message = "Ceres: " + cs.message;
      if (cs.message.rfind("Function tolerance", 0) == 0 || cs.message.rfind("Parameter tolerance", 0) == 0) {
        s.message += " (Ceres does not take the step that met the tolerance)";
      }
      usable = true;
      break;
    case ceres::NO_CONVERGENCE: {
      const bool out_of_iterations = !cs.iterations.empty() && cs.iterations.back().iteration >= options.max_iterations;
      s.status = out_of_iterations ? SolverStatus::kMaxIterations : SolverStatus::kTimeLimit;
      s.message = (out_of_iterations
                       ? "reached the maximum number of iterations (" + std::to_string(options.max_iterations) + ")"
                       : std::string("reached the time limit")) +
                  "; Ceres: " + cs.message;
      usable = true;
      break;
    }
    case ceres::FAILURE:
    case ceres::USER_FAILURE:
      s.status = SolverStatus::kDiverged;
      s.message = problem.errors().any() ? "a factor threw during the solve (" + problem.errors().first() + ")"
                                         : "Ceres failed: " + cs.message;
      s.message += "; the start values were kept";
      break;
  }
  if (usable && problem.errors().any()) {
    // Ceres recovered from a failed evaluation; say what failed anyway.
    s.message += " (a factor threw at a rejected step: " + problem.errors().first() + ")";
  }
  return usable;
}

// Writes Ceres' values back where they are usable and finite; otherwise the start values stay
// and the status says why.
void WriteResult(const FactorGraph& graph, Values* values, CeresProblem* problem, bool usable, SolverSummary* summary) {
  SolverSummary& s = *summary;
  if (usable && !problem->WriteBack(values)) {
    s.status = SolverStatus::kDiverged;
    s.message = "Ceres returned non-finite values (" + s.message + "); the start values were kept";
    usable = false;
  }
  if (usable) {
    s.final_chi2 = graph.Cost(*values);  // the objective; Optimize reports chi2 and cost apart
    if (!std::isfinite(s.final_chi2)) {
      problem->ResetBlocks();
      problem->WriteBack(values);
      s.status = SolverStatus::kDiverged;
      s.message = "chi2 of the values Ceres returned is not finite (" + s.message + "); the start values were kept";
      s.final_chi2 = s.initial_chi2;
    }
  }
}

SolverSummary Run(const FactorGraph& graph, Values* values, const SolverOptions& options, Clock::time_point t0) {
  SolverSummary s;
  s.algorithm = Algorithm::kCeres;
  s.linear_solver = LinearSolverType::kCholmod;
  s.num_factors = static_cast<int>(graph.size());
  std::string why;
  if (!options.IsValid(&why)) {
    s.message = "invalid options: " + why;
    return s;
  }
  if (!CeresRunsWith(options.linear_solver)) {
    s.message = std::string("the Ceres adapter solves with SPARSE_NORMAL_CHOLESKY over SuiteSparse (cholmod); '") +
                ToString(options.linear_solver) + "' is for the native solvers (gn, lm)";
    return s;
  }
  const std::set<Key> fixed = internal::ChooseFixed(graph, *values, &s);
  std::unique_ptr<CeresProblem> problem;
  try {
    problem = std::make_unique<CeresProblem>(graph, *values, fixed);
    why = CheckStart(graph, *values, *problem);
  } catch (const Error& e) {
    s.message = e.what();
    return s;
  }
  s.num_variables = problem->num_free();
  s.num_fixed = static_cast<int>(values->size()) - problem->num_free();
  s.num_residuals = problem->num_residuals();
  s.tangent_dim = problem->tangent_dim();
  if (!why.empty()) {
    s.message = why;
    s.initial_chi2 = s.final_chi2 = std::numeric_limits<double>::infinity();
    return s;
  }
  s.initial_chi2 = s.final_chi2 = graph.Cost(*values);

  // LM damping as a trust region: lambda = 1 / radius (see ceres_adapter.h).
  const double initial_radius = 1.0 / std::max(options.lm.initial_lambda, options.lm.min_lambda);
  if (problem->tangent_dim() == 0) {
    s.status = SolverStatus::kConverged;
    s.message = "nothing to optimise: every variable is fixed";
    IterationSummary it0;
    it0.chi2 = s.initial_chi2;
    it0.lambda = 1.0 / initial_radius;
    it0.seconds = s.total_seconds = SecondsSince(t0);
    s.log.push_back(it0);
    if (options.callback) options.callback(it0);
    return s;
  }

  ceres::Solver::Options co = CeresOptions(options, initial_radius);
  CallbackBridge bridge(&s, options, *problem, initial_radius, t0);
  co.callbacks.push_back(&bridge);
  if (!co.IsValid(&why)) {
    s.message = "these options cannot be given to Ceres: " + why;
    return s;
  }
  s.setup_seconds = SecondsSince(t0);

  ceres::Solver::Summary cs;
  {
    // Ceres' SPARSE_NORMAL_CHOLESKY factorises with CHOLMOD on this thread: hold CHOLMOD's
    // OpenMP teams to one thread as the native solvers do (Ceres' own threads are C++
    // threads, untouched).
    internal::SerialOpenMp serial;
    ceres::Solve(co, &problem->problem(), &cs);
  }

  s.setup_seconds += cs.preprocessor_time_in_seconds;
  s.linearize_seconds = cs.residual_evaluation_time_in_seconds + cs.jacobian_evaluation_time_in_seconds;
  s.solve_seconds = cs.linear_solver_time_in_seconds;
  for (const IterationSummary& it : s.log) {
    if (it.iteration == 0) continue;
    ++s.iterations;
    if (it.accepted) ++s.accepted_iterations;
  }
  bool usable = MapTermination(cs, *problem, options, &s);
  if (bridge.stopped_after() >= 0 && cs.termination_type == ceres::USER_SUCCESS) {
    s.status = SolverStatus::kStopped;
    s.message = "stopped by keep_going after iteration " + std::to_string(bridge.stopped_after());
  }
  WriteResult(graph, values, problem.get(), usable, &s);
  s.total_seconds = SecondsSince(t0);
  return s;
}

}  // namespace

SolverSummary backends::OptimizeWithCeres(const FactorGraph& graph, Values* values, const SolverOptions& options) {
  if (values == nullptr) throw InvalidArgument("OptimizeWithCeres: values must not be null");
  const Clock::time_point t0 = Clock::now();
  try {
    return Run(graph, values, options, t0);
  } catch (const std::exception& e) {
    // Memory ran out, or a factor threw outside Ceres' evaluation (values are only written
    // after a successful solve, so they are still the start values).
    SolverSummary s;
    s.algorithm = Algorithm::kCeres;
    s.num_factors = static_cast<int>(graph.size());
    s.status = SolverStatus::kDiverged;
    s.message = std::string("the solve stopped on an exception: ") + e.what() + "; values untouched";
    s.total_seconds = SecondsSince(t0);
    return s;
  }
}

}  // namespace tether
